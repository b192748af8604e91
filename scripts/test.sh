#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs the whole
# test suite; then the VM bench (the production SocketCAN and UART paths on Debian's
# kernel under qemu); then builds with ASan+UBSan and with TSan and runs the tests again;
# then cross-builds the robot side for aarch64 and armhf and runs its tests under qemu-user.
#   scripts/test.sh [--quick]   (--quick: skip the VM, sanitizer, fuzz and cross passes)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[[ ${1:-} == --quick ]] && quick=1

if ((quick)); then scripts/setup-deps.sh; else scripts/setup-deps.sh --vm; fi
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"   # every DDS program stays on loopback
start=$(date +%s)
stage() { echo "== test: $* (at $(( $(date +%s) - start )) s)"; }   # elapsed per stage: where CI's time goes

# The labels each sanitizer pass skips: benchmarks (timing), the tests labelled slow (minutes
# under a sanitizer), packaging and layers (they check files, not our running code); TSan
# also the tests that start no thread.
asan_skip='bench|slow|packaging|layers'
tsan_skip="$asan_skip|single-threaded"
stage "build (ci preset: release, -Werror)"
scripts/build.sh ci
stage "full suite"
ctest --preset ci -j2

if ((quick == 0)); then
  stage "VM bench: the HIL checks over SocketCAN (vcan0) and a 16550 UART (libserialport), Debian's kernel under qemu"
  scripts/vm-bench.sh --build build/ci
  stage "build (asan preset: ASan + UBSan, -Werror; only what the tests it runs need)"
  scripts/build-for-tests.sh asan -LE "$asan_skip"
  stage "unit and integration tests under ASan + UBSan"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --preset asan -j2 -LE "$asan_skip"
  stage "build (tsan preset: ThreadSanitizer, -Werror; only what the tests it runs need: not the tests labelled single-threaded, which start no thread)"
  scripts/build-for-tests.sh tsan -LE "$tsan_skip"
  stage "unit and integration tests under TSan"
  TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp:halt_on_error=1" ctest --preset tsan -j2 -LE "$tsan_skip"
  stage "fuzz targets (clang libFuzzer + ASan/UBSan), 8 s each, two at a time (longer: scripts/fuzz.sh SECONDS)"
  scripts/fuzz.sh 8
  stage "cross-build the robot side for aarch64 (-Werror); its tests and package under qemu-user"
  scripts/build-cross.sh aarch64 --test
  # armhf: the product and the tests of pure logic (labelled single-threaded: codecs,
  # geometry, odometry, safety, ... where 32 bits differ); the threaded and HIL tests run on
  # aarch64 above. All of armhf's: scripts/build-cross.sh armhf --test.
  stage "cross-build the robot side for armhf (-Werror, sysroot); its single-threaded tests and package under qemu-user"
  scripts/build-cross.sh armhf --test --tests-labelled single-threaded
fi
echo "== test: all passed in $(( $(date +%s) - start )) s"
