#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs the whole
# test suite; then the VM bench (the production SocketCAN and UART paths on Debian's
# kernel under qemu); then builds with ASan+UBSan and with TSan and runs the tests again;
# then cross-builds the robot side for aarch64 and armhf and runs its tests under qemu-user.
# The builds after the first run in the background while the tests run (see below).
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
if ((quick == 0)); then
  # The later passes' builds run in the background at idle priority (SCHED_IDLE, same
  # session, so the scheduler weighs it against the tests): the tests keep their CPU and
  # the builds take what they leave, which is most of it while the real-time tests sleep.
  # Each pass waits for its own build. One build at a time, in the order the passes need.
  bg=build/background-builds
  rm -rf "$bg"; mkdir -p "$bg"
  # The sanitizer passes build only what the tests they run need (scripts/build-for-tests.sh).
  chrt --idle 0 nice -n 19 bash -c '
    bg=$1 asan_skip=$2 tsan_skip=$3
    step() { local name=$1; shift
      if "$@" > "$bg/$name.log" 2>&1; then touch "$bg/$name.ok"; else touch "$bg/$name.failed"; exit 1; fi; }
    step asan scripts/build-for-tests.sh asan "$asan_skip"
    step tsan scripts/build-for-tests.sh tsan "$tsan_skip"
    step fuzz bash -c "cmake --preset fuzz && cmake --build --preset fuzz --target fuzzers"
    step aarch64 scripts/build-cross.sh aarch64
    step armhf scripts/build-cross.sh armhf' background-builds "$bg" "$asan_skip" "$tsan_skip" &
  bg_pid=$!
  kill_tree() { local c; for c in $(cat /proc/"$1"/task/*/children 2>/dev/null); do kill_tree "$c"; done; kill "$1" 2>/dev/null || true; }
  trap 'kill_tree $bg_pid' EXIT
  await_build() {   # waits for the background build NAME; its log on failure
    local since; since=$(date +%s)
    while [[ ! -e $bg/$1.ok && ! -e $bg/$1.failed ]]; do
      kill -0 "$bg_pid" 2>/dev/null || { echo "test: the background builds stopped before '$1'" >&2; exit 1; }
      sleep 2
    done
    if [[ -e $bg/$1.failed ]]; then tail -60 "$bg/$1.log"; echo "test: the $1 build FAILED (log: $bg/$1.log)" >&2; exit 1; fi
    echo "test: the $1 build is done ($(( $(date +%s) - since )) s spent waiting for it; log: $bg/$1.log)"
  }
fi
stage "full suite"
ctest --preset ci -j2

if ((quick == 0)); then
  stage "VM bench: the HIL checks over SocketCAN (vcan0) and a 16550 UART (libserialport), Debian's kernel under qemu"
  scripts/vm-bench.sh --build build/ci
  stage "build (asan preset: ASan + UBSan, -Werror): in the background since the full suite began"
  await_build asan
  stage "unit and integration tests under ASan + UBSan"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --preset asan -j2 -LE "$asan_skip"
  stage "build (tsan preset: ThreadSanitizer, -Werror; the tests labelled single-threaded, which start no thread, are not built): in the background"
  await_build tsan
  stage "unit and integration tests under TSan"
  TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp:halt_on_error=1" ctest --preset tsan -j2 -LE "$tsan_skip"
  stage "fuzz targets (clang libFuzzer + ASan/UBSan), 8 s each, two at a time (longer: scripts/fuzz.sh SECONDS)"
  await_build fuzz
  scripts/fuzz.sh 8
  stage "cross-build the robot side for aarch64 (-Werror); its tests and package under qemu-user"
  await_build aarch64
  scripts/build-cross.sh aarch64 --test
  stage "cross-build the robot side for armhf (-Werror, sysroot); its tests and package under qemu-user"
  await_build armhf
  scripts/build-cross.sh armhf --test
  wait "$bg_pid"
fi
echo "== test: all passed in $(( $(date +%s) - start )) s"
