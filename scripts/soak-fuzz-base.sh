#!/usr/bin/env bash
# A long cairn-fuzz-base run (CI runs 60 s of it: ctest -R fuzz_base_smoke). Builds the ci
# preset if needed, then fuzzes a cairn-base for SECONDS (default 1800) beside a simulated
# fleet; a second run sweeps all 65536 ids of every topic (the most DDS instances a reader
# can be made to hold). Reports land in build/soak-fuzz-base/*.json; exit status 1 if the
# base crashed, its state went non-finite, its memory kept growing, or a real robot's
# estimate moved beyond the tolerance (docs/fuzz-base.md).
#   scripts/soak-fuzz-base.sh [SECONDS] [RATE]     e.g. scripts/soak-fuzz-base.sh 600 5000
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-1800}
rate=${2:-3000}
cmake --preset ci >/dev/null
cmake --build --preset ci --target cairn-fuzz-base cairn-base >/dev/null
out=build/soak-fuzz-base
mkdir -p "$out"
bin=build/ci/tools/fuzz_base/cairn-fuzz-base
status=0
echo "soak: random ids, ${secs} s at ${rate} samples/s"
"$bin" --seconds "$secs" --rate "$rate" --seed "$RANDOM" --json > "$out/random.json" || status=1
python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("  pass", d["pass"], "rss", d["base"]["rss_mib"], "max error", d["max_position_error_m"], "m", d["failures"])' "$out/random.json"
# The sweep fills every reader with all 65536 keys: its memory levels off at the key space.
echo "soak: sweeping every id, ${secs} s at ${rate} samples/s"
"$bin" --seconds "$secs" --rate "$rate" --sweep-ids --max-rss-growth-mib 64 --json > "$out/sweep.json" || status=1
python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("  pass", d["pass"], "rss", d["base"]["rss_mib"], "max error", d["max_position_error_m"], "m", d["failures"])' "$out/sweep.json"
echo "soak: $([ $status = 0 ] && echo PASS || echo FAIL) (reports in $out/)"
exit $status
