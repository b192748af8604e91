#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the fleet live —
# a base station and three robots over DDS on the loopback-only profile.
#   scripts/demo.sh [--duration SECONDS]   (default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
duration=20
while (($#)); do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    -h|--help) sed -n '2,4p' "$0"; exit 0 ;;
    *) echo "demo: unknown option '$1'" >&2; exit 2 ;;
  esac
done

scripts/setup-deps.sh
echo "demo: building (release preset)..."
scripts/build.sh release >/dev/null
B=build/release
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"   # belt and braces: loopback only

pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT INT TERM

echo "demo: base station + 3 robots for ${duration} s; robot 2 crashes at 8 s and restarts at 12 s"
$B/basestation/cairn-base --config config/base.toml --duration "$duration" &
base=$!
sleep 0.5
for id in 1 2 3; do
  $B/firmware/cairn-robot --config config/robot.toml --id "$id" --duration "$duration" 2>/dev/null &
  pids+=($!)
done
sleep 7.5
{ kill -9 "${pids[1]}" && wait "${pids[1]}"; } 2>/dev/null || true
sleep 4
$B/firmware/cairn-robot --config config/robot.toml --id 2 --duration "$((duration - 12))" 2>/dev/null &
pids+=($!)
wait "$base"
echo "demo: done"
