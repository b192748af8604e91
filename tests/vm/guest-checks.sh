#!/bin/sh
# The VM bench's checks, run inside the guest by scripts/vm-bench.sh (the project's root is
# the shared host root, read-only; /tmp is the guest's). The in-process HIL test runs
# against the production device backends: the CANopen drives on SocketCAN (vcan0) and the
# LMS2xx on a 16550 UART opened with libserialport, its emulator on the UART at the other
# end of the null-modem cable.
#   tests/vm/guest-checks.sh BUILD_DIR [GTEST_FILTER]
set -eu
build=${1:?usage: guest-checks.sh BUILD_DIR [GTEST_FILTER]}
filter=${2:-*}
export CAIRN_VM_CAN=vcan0 CAIRN_VM_LMS_UART=/dev/ttyS2 CAIRN_VM_LMS_URI=serial:/dev/ttyS1 CAIRN_VM_LMS_BAUD=38400
# A release build on a software-emulated CPU: the timing bounds scale as under qemu-user.
export CAIRN_TIMING_SLACK=5
echo "guest: $(uname -r), $(nproc) CPUs; $build/tests/executive_hil_test --gtest_filter=$filter"
"$build/tests/executive_hil_test" --gtest_filter="$filter"
[ "$filter" = "*" ] || exit 0

# The production programs over the same backends: cairn-hil serves one robot's devices
# (drives on vcan0, laser on ttyS2), cairn-base holds the link, and cairn-robot, configured
# by the file cairn-hil writes (socketcan:vcan0, serial:/dev/ttyS1 at 38400), drives its
# route for 25 s. Passes when the robot exits cleanly, having travelled at least 8 m (the
# route at 0.6 m/s, less the start-up; about 12 m is usual), matched at least 80 scans
# (about 5 a second at 38400 Bd) and 90 % of them, and received the base's corrections.
run=/tmp/vm-robot
mkdir -p "$run"
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
  --out "$run/robots" --truth "$run/truth.txt" --report 5 --duration 45 \
  --can-iface "$CAIRN_VM_CAN" --lms-uart "$CAIRN_VM_LMS_UART" --lms-host-uri "$CAIRN_VM_LMS_URI" \
  --lms-baud "$CAIRN_VM_LMS_BAUD" > "$run/hil.log" 2>&1 &
hil=$!
for i in $(seq 100); do grep -q "cairn-hil: ready" "$run/hil.log" && break; sleep 0.1; done
grep "cairn-hil: robot 1" "$run/hil.log"
"$build/basestation/cairn-base" --config "$run/base.toml" --duration 40 > "$run/base.log" 2>&1 &
base=$!
rc=0
"$build/firmware/cairn-robot" --config "$run/robots/robot-1.toml" --duration 25 > "$run/robot.log" 2>&1 || rc=$?
kill "$base" "$hil" 2>/dev/null || true
wait "$base" "$hil" 2>/dev/null || true
cat "$run/robot.log"
travelled=$(awk '!/^#/ {d = $6} END {print d + 0}' "$run/truth.txt")
echo "guest: cairn-robot exit status $rc; travelled ${travelled} m"
[ "$rc" -eq 0 ] || { echo "guest: FAIL: cairn-robot exited $rc"; exit 1; }
awk -v d="$travelled" 'BEGIN {exit !(d >= 8)}' || { echo "guest: FAIL: travelled only ${travelled} m"; exit 1; }
# The robot's last status line: "...; scans N (matched M); ...; corrections C; ..."
last=$(grep "robot: robot 1: " "$run/robot.log" | tail -1)
scans=$(echo "$last" | sed -n 's/.*scans \([0-9]*\) (matched \([0-9]*\)).*corrections \([0-9]*\).*/\1 \2 \3/p')
echo "guest: scans, matched, corrections: ${scans:-none}"
set -- $scans
[ $# -eq 3 ] && [ "$1" -ge 80 ] && [ $(( $2 * 10 )) -ge $(( $1 * 9 )) ] && [ "$3" -ge 1 ] ||
  { echo "guest: FAIL: too few scans or matches, or no correction from the base"; exit 1; }
echo "guest: all VM checks passed"
