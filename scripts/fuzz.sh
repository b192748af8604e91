#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan+UBSan) and runs each for a bounded time
# from its seed corpus (tests/fuzz/corpus/NAME), one target per core at a time. A crash
# fails the run and leaves the input in build/fuzz/crashes/.
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [JOBS]   (defaults: 30 s, one job per core)
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-30}
jobs=${2:-$(nproc)}
[[ $secs =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: SECONDS must be a positive integer, not '$secs'" >&2; exit 2; }
[[ $jobs =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: JOBS must be a positive integer, not '$jobs'" >&2; exit 2; }
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz --target fuzzers >/dev/null   # the fuzz targets only
work=build/fuzz/run
mkdir -p "$work" build/fuzz/crashes
declare -A corpus=([fuzz_lms_codec]=lms_replies [fuzz_lms_request]=lms_requests [fuzz_canopen]=canopen [fuzz_modbus]=modbus [fuzz_modbus_rtu]=modbus_rtu [fuzz_carmen]=carmen [fuzz_network]=network [fuzz_files]=files [fuzz_mcap]=mcap [fuzz_web_command]=web_command [fuzz_foxglove_op]=foxglove_op)
targets=($(printf '%s\n' "${!corpus[@]}" | sort))

# One target: its own working corpus (a copy: the seeds in the repository stay as they are)
# and its own log; the exit status is libFuzzer's.
run_one() {
  local target=$1 dir="$work/${corpus[$1]}"
  mkdir -p "$dir"
  cp -n tests/fuzz/corpus/${corpus[$target]}/* "$dir/" 2>/dev/null || true
  "build/fuzz/tests/fuzz/$target" -max_total_time="$secs" -artifact_prefix=build/fuzz/crashes/ \
      -print_final_stats=1 "$dir" > "build/fuzz/$target.log" 2>&1
}

declare -A pid_of
failed=()
for target in "${targets[@]}"; do
  while (( $(jobs -rp | wc -l) >= jobs )); do wait -n || true; done
  echo "fuzz: $target for ${secs} s (corpus ${corpus[$target]})"
  run_one "$target" &
  pid_of[$target]=$!
done
for target in "${targets[@]}"; do
  if wait "${pid_of[$target]}"; then
    echo "fuzz: $target clean"
    { grep -E "stat::number_of_executed_units|stat::new_units_added" "build/fuzz/$target.log" || true; } | sed 's/^/  /'
  else
    tail -30 "build/fuzz/$target.log"
    echo "fuzz: $target FAILED (crash input in build/fuzz/crashes/)"
    failed+=("$target")
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: ${#failed[@]} target(s) failed: ${failed[*]}"
  exit 1
fi
echo "fuzz: all ${#targets[@]} targets clean"
