#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan+UBSan) and runs each for a bounded time
# from its seed corpus (tests/fuzz/corpus/NAME). A crash fails the run and leaves the
# input in build/fuzz/crashes/.   scripts/fuzz.sh [SECONDS_PER_TARGET]   (default 30)
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-30}
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz --target fuzzers >/dev/null   # the fuzz targets only
work=build/fuzz/run
mkdir -p "$work" build/fuzz/crashes
declare -A corpus=([fuzz_lms_codec]=lms_replies [fuzz_lms_request]=lms_requests [fuzz_canopen]=canopen [fuzz_modbus]=modbus [fuzz_modbus_rtu]=modbus_rtu [fuzz_carmen]=carmen [fuzz_network]=network [fuzz_files]=files)
for target in "${!corpus[@]}"; do
  dir="$work/${corpus[$target]}"
  mkdir -p "$dir"
  cp -n tests/fuzz/corpus/${corpus[$target]}/* "$dir/" 2>/dev/null || true
  echo "fuzz: $target for ${secs} s (corpus ${corpus[$target]})"
  if ! "build/fuzz/tests/fuzz/$target" -max_total_time="$secs" -artifact_prefix=build/fuzz/crashes/ \
        -print_final_stats=1 "$dir" > "build/fuzz/$target.log" 2>&1; then
    tail -30 "build/fuzz/$target.log"
    echo "fuzz: $target FAILED (crash input in build/fuzz/crashes/)"
    exit 1
  fi
  grep -E "stat::number_of_executed_units|stat::new_units_added" "build/fuzz/$target.log" | sed 's/^/  /'
done
echo "fuzz: all targets clean"
