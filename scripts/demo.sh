#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the HIL demo live — three
# robots explore the office world (hil/worlds/office.world) through emulated devices that
# speak the real wire protocols (SICK LMS2xx on ptys, CiA 402 drives on a CAN bus,
# Modbus power boards), each run by the production cairn-robot; cairn-base fuses them,
# builds the global map and assigns frontiers from the robots' bids, all over DDS on the
# loopback-only profile. It ends when the base reports the office explored, or at the
# time cap. Robot 2's e-stop is pressed for 3 s at 30 s. cairn-record records every topic
# into hil-run/cairn.mcap (docs/recording.md); a failed recording fails the demo.
#   scripts/demo.sh [--duration SECONDS] [--robots N] [--no-record]   (defaults: cap 240 s, 3 robots)
set -euo pipefail
cd "$(dirname "$0")/.."
duration=240
robots=3
record=1
while (($#)); do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    --robots) robots=$2; shift 2 ;;
    --no-record) record=0; shift ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "demo: unknown option '$1'" >&2; exit 2 ;;
  esac
done

scripts/setup-deps.sh
echo "demo: building (release preset)..."
scripts/build.sh release >/dev/null
B=build/release
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"   # belt and braces: loopback only
run=hil-run
rm -rf "$run"
mkdir -p "$run"

pids=()
recorder=()  # apart from pids: the script stops it last, after the robots and the bench
cleanup() { kill -INT "${pids[@]}" "${recorder[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
trap 'cleanup; exit 130' INT TERM

# The bench's robot template, exploring: no scripted route, bids on the base's map.
{ cat config/robot-hil.toml; printf '\n[explore]\nenabled = true\n'; } > "$run/robot-template.toml"
echo "demo: HIL bench with $robots robot(s) exploring the office world; logs in $run/"
$B/hil/cairn-hil robots --world hil/worlds/office.world --count "$robots" --template "$run/robot-template.toml" \
  --out "$run" --truth "$run/truth.txt" --report 10 --fault 30:2:estop:3 --duration "$((duration + 5))" \
  > >(tee "$run/hil.log") 2>&1 &
pids+=($!)
for _ in $(seq 100); do grep -q "cairn-hil: ready" "$run/hil.log" 2>/dev/null && break; sleep 0.1; done
grep -q "cairn-hil: ready" "$run/hil.log" || { echo "demo: the HIL bench did not come up" >&2; exit 1; }

# The recorder before the base and the robots, so it has every message from the start.
if ((record)); then
  $B/tools/recording/cairn-record --config config/base-hil.toml -o "$run/cairn.mcap" --progress 30 >"$run/record.log" 2>&1 &
  recorder=($!)
  for _ in $(seq 50); do grep -q "record: recording" "$run/record.log" 2>/dev/null && break; sleep 0.1; done
  grep -q "record: recording" "$run/record.log" || { echo "demo: cairn-record did not start:" >&2; cat "$run/record.log" >&2; exit 1; }
  echo "demo: recording every topic to $run/cairn.mcap"
fi

# The live web view (docs/web-view.md): loopback, any free port, a token made for this run.
token=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
{ cat config/base-hil.toml; printf '\n[web]\nenabled = true\nport = 0\ntoken = "%s"\n' "$token"; } > "$run/base.toml"
$B/basestation/cairn-base --config "$run/base.toml" --duration "$duration" 2>"$run/base.err" > >(tee "$run/base.out") &
base=$!
pids+=("$base")
sleep 0.5
for _ in $(seq 50); do grep -q "^web view listening" "$run/base.out" 2>/dev/null && break; sleep 0.1; done
web_port=$(sed -n 's/^web view listening on 127\.0\.0\.1 port \([0-9]*\)$/\1/p' "$run/base.out" | head -1)
if [ -n "$web_port" ]; then
  echo "demo: live view (open it in a browser): http://127.0.0.1:$web_port/?token=$token"
  echo "demo: in Foxglove (Open connection, Foxglove WebSocket): ws://127.0.0.1:$web_port/?token=$token"
else
  echo "demo: the web view did not start (see $run/base.err); the demo goes on without it" >&2
fi
for id in $(seq "$robots"); do
  $B/firmware/cairn-robot --config "$run/robot-$id.toml" --duration "$duration" 2>"$run/robot-$id.log" &
  pids+=($!)
done
# The e-stop latches: robot 2 stays stopped after its release (30-33 s) until an operator
# resets it. Here the operator does so from the base at ~36 s (docs/firmware.md, "E-stop").
if [ "$robots" -ge 2 ]; then
  (sleep 36; echo "demo: operator resets robot 2's released e-stop from the base";
   $B/basestation/cairn-base --config config/base-hil.toml --reset-estop 2 >"$run/reset.log" 2>&1) &
fi
# An operator's request (the seed's "visit (x, y)"): robot 3 leaves its frontier for the
# corridor's middle; the others cover for it, and it rejoins exploration when it arrives.
if [ "$robots" -ge 3 ]; then
  (sleep 50; echo "demo: operator asks robot 3 to visit (12.5, 10.0) from the base";
   $B/basestation/cairn-base --config config/base-hil.toml --visit 3 12.5 10.0 >"$run/visit.log" 2>&1) &
fi
# Live coverage against the world's ground truth: every 20 s the base is asked for its
# map (SIGUSR1) and cairn-map-quality compares it with the world.
world=hil/worlds/office.world
coverage() {
  $B/tools/map_quality/cairn-map-quality --map "$run/map/map.yaml" --world "$world" 2>/dev/null |
    awk '/^coverage/ {c=$2} /^agreement/ {a=$2} END {if (c != "") printf "coverage %.1f %% of the reachable free space, agreement %.1f %%", c, a}'
}
t0=$(date +%s)
next=20
while kill -0 "$base" 2>/dev/null; do
  sleep 1
  if grep -q "exploration complete" "$run/base.err" 2>/dev/null; then
    echo "demo: the base reports the office explored after $(( $(date +%s) - t0 )) s"
    sleep 2
    grep -m1 -o "explored: .*" "$run/base.err" | sed 's/^/demo: the base: /' || true
    kill -INT "$base" 2>/dev/null || true
    break
  fi
  if (( $(date +%s) - t0 >= next )); then
    next=$((next + 20))
    kill -USR1 "$base" 2>/dev/null || true
    sleep 1
    echo "demo: at $(( $(date +%s) - t0 )) s: $(coverage)"
  fi
done
wait "$base" || true
for p in "${pids[@]:2}"; do kill -INT "$p" 2>/dev/null || true; done  # the robots
sleep 2
# The bench last: its ground truth file is complete only once it has exited.
kill -INT "${pids[0]}" 2>/dev/null || true
wait "${pids[0]}" 2>/dev/null || true
record_status=0
if ((record)); then  # SIGINT: the recorder writes its summary and footer and exits 0, or says why not
  kill -INT "${recorder[0]}" 2>/dev/null || true
  wait "${recorder[0]}" || record_status=$?
  recorder=()
fi
echo
echo "demo: robots' own view (last progress lines; full logs in $run/robot-N.log):"
for id in $(seq "$robots"); do
  { grep "robot $id:" "$run/robot-$id.log" || true; } | tail -1 | sed 's/^\[[^]]*\] *info *//'
  { grep "robot $id explore:" "$run/robot-$id.log" || true; } | tail -1 | sed 's/^\[[^]]*\] *info *//'
done
{ grep "explore:" "$run/base.out" || true; } | tail -1
[ -f "$run/reset.log" ] && echo "demo: $(cat "$run/reset.log")"
[ -f "$run/visit.log" ] && echo "demo: $(cat "$run/visit.log")"
echo
echo "demo: the base's map at exit ($run/map: map.png with trajectories and landmark ellipses, map.pgm + map.yaml for map_server, landmarks.json, trajectories.csv), against the ground truth:"
if [ ! -f "$run/map/map.yaml" ]; then
  echo "demo: no map was written (see $run/base.err)"
else
  $B/tools/map_quality/cairn-map-quality --map "$run/map/map.yaml" --world "$world" --landmarks "$run/map/landmarks.json" \
    --trajectories "$run/map/trajectories.csv" --ground-truth "$run/truth.txt" | sed 's/^/  /' ||
    echo "demo: cairn-map-quality could not score the map (its message is above)"
fi
if ((record)); then
  if ((record_status == 0)); then
    echo "demo: $(tail -n1 "$run/record.log")"
    echo "demo: open $run/cairn.mcap in Foxglove, or replay it with $B/tools/recording/cairn-replay (docs/recording.md)"
  else
    echo "demo: the recording FAILED (exit $record_status): $(tail -n1 "$run/record.log")" >&2
  fi
fi
echo "demo: done (ground truth in $run/truth.txt)"
exit $((record_status != 0))
