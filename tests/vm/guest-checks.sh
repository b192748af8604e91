#!/bin/sh
# The VM bench's checks, run inside the guest by scripts/vm-bench.sh (the project's root is
# the shared host root, read-only; /tmp is the guest's). The in-process HIL test runs
# against the production device backends: the CANopen drives on SocketCAN (vcan0) and the
# LMS2xx on a 16550 UART opened with libserialport, its emulator on the UART at the other
# end of the null-modem cable. Then the production programs run over the same backends.
#   tests/vm/guest-checks.sh BUILD_DIR [GTEST_FILTER]   (a filter runs only that part)
set -eu
build=${1:?usage: guest-checks.sh BUILD_DIR [GTEST_FILTER]}
filter=${2:-*}
fail() { echo "guest: FAIL: $*"; exit 1; }
export CAIRN_VM_CAN=vcan0 CAIRN_VM_LMS_UART=/dev/ttyS2 CAIRN_VM_LMS_URI=serial:/dev/ttyS1 CAIRN_VM_LMS_BAUD=38400
# A release build on a software-emulated CPU: the timing bounds scale as under qemu-user.
export CAIRN_TIMING_SLACK=5
run=/tmp/vm-robot
mkdir -p "$run"
echo "guest: $(uname -r), $(nproc) CPUs; $build/tests/executive_hil_test --gtest_filter=$filter"
rc=0
"$build/tests/executive_hil_test" --gtest_filter="$filter" > "$run/hil-test.log" 2>&1 || rc=$?
cat "$run/hil-test.log"
[ "$rc" -eq 0 ] || fail "executive_hil_test exited $rc"
# The environment reached the test (else it ran on the pty and the user-space bus and
# skipped the SocketCAN test, and would pass all the same).
grep -q "^VM bench: drives on socketcan:$CAIRN_VM_CAN" "$run/hil-test.log" || fail "the test did not use the VM's devices"
! grep -q "^\[  SKIPPED \]" "$run/hil-test.log" || fail "a test was skipped on the VM bench"
[ "$filter" = "*" ] || exit 0

# The production programs over the same backends: cairn-hil serves one robot's devices
# (drives on vcan0, laser on ttyS2), cairn-base holds the link, and cairn-robot, configured
# by the file cairn-hil writes (socketcan:vcan0, serial:/dev/ttyS1 at 38400), drives its
# route for 25 s. Passes when each exits cleanly and the robot has travelled at least 8 m
# (the route at 0.6 m/s, less the start-up; about 12 m is usual), matched at least 80
# scans (about 5 a second at 38400 Bd) and 90 % of them, and received the base's
# corrections.
cat > "$run/base.toml" <<TOML
[dds]
profile = "loopback"
[fusion]
state_dir = "$run/base-state"
[mapper]
export_dir = "$run/map"
[[robot]]
id = 1
initial_pose = [1.5, 10.0, 0.0]
TOML
"$build/hil/cairn-hil" robots --world hil/worlds/office.world --count 1 --template config/robot-hil.toml \
  --out "$run/robots" --truth "$run/truth.txt" --report 5 --duration 60 \
  --can-iface "$CAIRN_VM_CAN" --lms-uart "$CAIRN_VM_LMS_UART" --lms-host-uri "$CAIRN_VM_LMS_URI" \
  --lms-baud "$CAIRN_VM_LMS_BAUD" > "$run/hil.log" 2>&1 &
hil=$!
i=0
until grep -q "cairn-hil: ready" "$run/hil.log"; do
  i=$((i + 1))
  if ! kill -0 "$hil" 2>/dev/null || [ "$i" -gt 300 ]; then
    cat "$run/hil.log"
    fail "cairn-hil did not get ready"
  fi
  sleep 0.1
done
grep "cairn-hil: robot 1" "$run/hil.log"
"$build/basestation/cairn-base" --config "$run/base.toml" --duration 60 > "$run/base.log" 2>&1 &
base=$!
rc=0
"$build/firmware/cairn-robot" --config "$run/robots/robot-1.toml" --duration 25 > "$run/robot.log" 2>&1 || rc=$?
kill "$base" "$hil" 2>/dev/null || true
base_rc=0 hil_rc=0
wait "$base" || base_rc=$?
wait "$hil" || hil_rc=$?
cat "$run/robot.log"
[ "$rc" -eq 0 ] || fail "cairn-robot exited $rc"
[ "$base_rc" -eq 0 ] || { cat "$run/base.log"; fail "cairn-base exited $base_rc"; }
[ "$hil_rc" -eq 0 ] || { cat "$run/hil.log"; fail "cairn-hil exited $hil_rc"; }
[ -s "$run/truth.txt" ] || { cat "$run/hil.log"; fail "cairn-hil wrote no ground truth"; }
travelled=$(awk '!/^#/ {d = $6} END {print d + 0}' "$run/truth.txt")
echo "guest: cairn-robot travelled ${travelled} m"
awk -v d="$travelled" 'BEGIN {exit !(d >= 8)}' || fail "travelled only ${travelled} m"
# The robot's last status line: "...; scans N (matched M); ...; corrections C; ..."
last=$(grep "robot: robot 1: " "$run/robot.log" | tail -1)
counts=$(echo "$last" | sed -n 's/.*scans \([0-9]*\) (matched \([0-9]*\)).*corrections \([0-9]*\).*/\1 \2 \3/p')
echo "guest: scans, matched, corrections: ${counts:-none}"
set -- $counts
[ $# -eq 3 ] || fail "no status line with scans and corrections from cairn-robot"
[ "$1" -ge 80 ] && [ $(($2 * 10)) -ge $(($1 * 9)) ] && [ "$3" -ge 1 ] ||
  fail "too few scans ($1) or matches ($2), or no correction from the base ($3)"
echo "guest: all VM checks passed"
