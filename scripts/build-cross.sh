#!/usr/bin/env bash
# Cross-builds the robot side (common, drivers, firmware, cairn-robot, the probe tools and
# their tests) for a robot computer, with warnings as errors, and with --test runs the
# target's unit tests under qemu-user (CTest label `cross`).
#   scripts/build-cross.sh aarch64 [--test]     64-bit Arm -> build/aarch64
#   scripts/build-cross.sh armhf [--test]       32-bit Arm -> build/armhf
#   ... --tests-labelled REGEX                  build and run only the tests with a matching label
#                                               (CI's armhf pass: single-threaded)
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:-}
case "$target" in
  aarch64|armhf) ;;
  -h|--help|"") sed -n '2,8p' "$0"; [[ -n "$target" ]]; exit $? ;;
  *) echo "build-cross: unknown target '$target' (aarch64 or armhf)" >&2; exit 2 ;;
esac
shift
run_tests=0
labels=''
while (($#)); do
  case "$1" in
    --test) run_tests=1; shift ;;
    --tests-labelled) labels=${2:?build-cross: --tests-labelled needs a label regex}; shift 2 ;;
    *) echo "build-cross: unknown option '$1'" >&2; exit 2 ;;
  esac
done
scripts/setup-cross.sh "$target"
cmake --preset "$target" ${labels:+"-DCAIRN_TEST_LABELS=$labels"} >/dev/null   # the preset resets it otherwise
cmake --build --preset "$target"
echo "build-cross: $target binaries in build/$target (file build/$target/firmware/cairn-robot: $(file -b build/$target/firmware/cairn-robot | cut -d, -f1-2))"
if ((run_tests)); then
  echo "build-cross: running the $target tests${labels:+ labelled '$labels'} under qemu-user..."
  if ! ctest --preset "$target" -j2 -L cross; then
    echo "build-cross: TESTS FAILED ON TARGET $target (under qemu-user; see above)" >&2
    exit 1
  fi
fi
