#!/usr/bin/env bash
# Robots that see each other, on the HIL bench (issue 14's figure): three robots drive
# their concentric loops in the pole-free hall (hil/worlds/hall-bare.world) in ONE world
# (`cairn-hil robots --shared-world`: each laser sees the others' coded markers), with
# the production cairn-robot and cairn-base over DDS on loopback. Run twice, the base
# fusing the robots' sightings of each other and ignoring them (each robot alone); prints
# each robot's pose RMSE against the bench's ground truth (cairn-map-quality).
# The robots report drift relative to their local maps ([mapping] map_relative_drift,
# docs/markers.md) and drive at 0.8 m/s looking 0.6 m ahead, as cairn-sim's tours do.
#   scripts/hall-bench.sh [--duration SECONDS]   (default 150; results in hall-run/)
# BUILD=build/ci uses another build's binaries (default: builds the release preset).
set -euo pipefail
cd "$(dirname "$0")/.."
duration=150
while (($#)); do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "hall-bench: unknown option '$1'" >&2; exit 2 ;;
  esac
done
if [ -z "${BUILD:-}" ]; then
  scripts/setup-deps.sh
  echo "hall-bench: building (release preset)..."
  scripts/build.sh release >/dev/null
fi
B=${BUILD:-build/release}
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"   # DDS stays on loopback
world=hil/worlds/hall-bare.world

pids=()
cleanup() { kill -INT "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
trap 'cleanup; exit 130' INT TERM

one_run() {  # NAME FUSE_SIGHTINGS(true|false)
  local run=hall-run/$1
  rm -rf "$run"
  mkdir -p "$run"
  sed -e 's/^speed = 0.6/speed = 0.8/' -e 's/^lookahead_time_s = 1.0 .*/lookahead_time_s = 0.75/' \
    config/robot-hil.toml > "$run/robot-template.toml"
  printf '\n[mapping]\nmap_relative_drift = true\n' >> "$run/robot-template.toml"
  # The base: the hall's start poses define the map frame (hil/worlds/hall-bare.world).
  cat > "$run/base.toml" <<EOT
[base]
name = "base-hall"
[dds]
profile = "loopback"
[fleet]
stale_after_s = 3.0
table_period_s = 2.0
[fusion]
enabled = true
state_dir = "$run/base-state"
correction_period_s = 0.2
map_period_s = 1.0
robot_observations = $2
[[robot]]
id = 1
initial_pose = [4.0, 3.0, 0.0]
initial_sigma = [0.05, 0.05, 0.02]
[[robot]]
id = 2
initial_pose = [7.0, 6.0, 0.0]
initial_sigma = [0.05, 0.05, 0.02]
[[robot]]
id = 3
initial_pose = [10.0, 8.0, 0.0]
initial_sigma = [0.05, 0.05, 0.02]
[mapper]
export_dir = "$run/map"
EOT
  pids=()
  "$B/hil/cairn-hil" robots --world "$world" --count 3 --template "$run/robot-template.toml" --shared-world \
    --out "$run" --truth "$run/truth.txt" --report 30 --duration "$((duration + 8))" > "$run/hil.log" 2>&1 &
  local hil=$!
  pids+=("$hil")
  for _ in $(seq 100); do grep -q "cairn-hil: ready" "$run/hil.log" 2>/dev/null && break; sleep 0.1; done
  grep -q "cairn-hil: ready" "$run/hil.log" || { echo "hall-bench: the HIL bench did not come up ($run/hil.log)" >&2; exit 1; }
  "$B/basestation/cairn-base" --config "$run/base.toml" --duration "$duration" > "$run/base.out" 2> "$run/base.err" &
  local base=$!
  pids+=("$base")
  sleep 0.5
  for id in 1 2 3; do
    "$B/firmware/cairn-robot" --config "$run/robot-$id.toml" --duration "$duration" 2> "$run/robot-$id.log" &
    pids+=($!)
  done
  wait "$base" || true
  sleep 3
  kill -INT "$hil" 2>/dev/null || true  # its truth file is complete once it has exited
  wait "$hil" 2>/dev/null || true
  echo "== $1 (sightings fused: $2)"
  { grep -h "robots seen" "$run/base.out" || true; } | tail -1 | grep -o "robots seen [^)]*)[^,]*" | sed 's/^/  the base: /' || true
  { grep -hE "cairn-hil: (contacts|final)" "$run/hil.log" || true; } | sed 's/^/  /'
  "$B/tools/map_quality/cairn-map-quality" --map "$run/map/map.yaml" --world "$world" \
    --trajectories "$run/map/trajectories.csv" --ground-truth "$run/truth.txt" | grep -E "robot" | sed 's/^/  /' ||
    echo "hall-bench: cairn-map-quality could not score the run (see $run/base.err)"
}

echo "hall-bench: two runs of $duration s each; logs in hall-run/"
one_run cooperative true
one_run alone false
