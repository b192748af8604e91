#!/usr/bin/env bash
# Boots a copy of a robot image (scripts/make-image.sh) under qemu-system-aarch64 and checks
# from inside the guest that it came up as a robot computer (docs/robot-image.md).
#
#   scripts/image-test.sh robot.img [options]
#
#   --timeout SECONDS   give up after this long (default 900: TCG emulation is slow)
#   --work-dir DIR      where the copy, the firmware variables and the console log go
#                       (default /tmp/cairn-image/test.PID; the copy is removed afterwards)
#   --keep              keep the copy and the log (kept anyway when a check fails or on a timeout)
#   --cpu MODEL         qemu's -cpu (default max,pauth-impdef=on)
#   --smp N             guest CPUs (default 2: the default configuration pins the RT loop to CPU 1)
#   --grow SIZE         make the copy this much larger than the image, as a larger card is
#                       (default 512M; 0 to skip), to check that the root grows at first boot
#
# The image itself is never modified. Its copy boots through UEFI (Debian's AAVMF firmware,
# qemu-efi-aarch64) and the image's own GRUB and kernel, on TCG (-M virt), with NO network
# device (-nic none): DDS inside the guest has only the guest's loopback. Into the copy's root
# file system (debugfs, no mount) go a test-only unit and script that wait for the boot to
# finish, run the checks, print one "CAIRN-CHECK <name> PASS|FAIL <detail>" line per check on
# the serial console and power the guest off. The host reads the console log.
# Checks: multi-user.target reached (and the boot time), no failed unit but cairn-robot,
# cairn-robot.service enabled and started by systemd, --check-config clean, the watchdog
# (WatchdogSec) and RT limits set, what cairn-robot did with the image's configuration (with
# [devices] it needs the robot's hardware: without it cairn-robot must stop with the device
# named and systemd must restart it), then cairn-robot run by systemd with that configuration
# minus [devices] (status only, a runtime drop-in): READY, watchdog pings arriving, its RT
# limits; sshd up, keys only, host keys made at first boot; hostname; the root file system
# grown to the larger card.
# Exit status: 0 every check passed; 1 a check failed, or the guest did not finish in time
# (the console log's tail is shown); 2 a usage error.
set -euo pipefail

prog="image-test"
here=$(cd "$(dirname "$0")/.." && pwd)
die() { echo "$prog: $1" >&2; exit "${2:-1}"; }
usage() { sed -n '2,33p' "$0"; }
t0=$SECONDS
stage() { echo "$prog: [$((SECONDS - t0)) s] $*"; }

image="" timeout=900 work="" keep=0 cpu="max,pauth-impdef=on" smp=2 grow=512M
value() { [[ $# -ge 2 && -n "$2" ]] || { echo "$prog: $1 needs a value (try --help)" >&2; exit 2; }; }
while (($#)); do
  case "$1" in
    --timeout) value "$@"; timeout=$2; shift 2 ;;
    --work-dir) value "$@"; work=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --cpu) value "$@"; cpu=$2; shift 2 ;;
    --smp) value "$@"; smp=$2; shift 2 ;;
    --grow) value "$@"; grow=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "$prog: unknown option '$1' (try --help)" >&2; exit 2 ;;
    *) [[ -z "$image" ]] || { echo "$prog: one image only" >&2; exit 2; }; image=$1; shift ;;
  esac
done
[[ -n "$image" ]] || { echo "$prog: name the image (try --help)" >&2; exit 2; }
[[ "$timeout" =~ ^[1-9][0-9]*$ ]] || die "--timeout '$timeout': expected seconds" 2
[[ "$smp" =~ ^[1-9][0-9]?$ ]] || die "--smp '$smp': expected a CPU count" 2
[[ "$grow" =~ ^(0|[1-9][0-9]*[MG])$ ]] || die "--grow '$grow': expected 0 or a size in M or G" 2
[[ -f "$image" ]] || die "image '$image' not found"
command -v sfdisk >/dev/null || die "needs sfdisk to read the image's partition table (apt-get install fdisk)"

# ---- the image's layout: the root partition (type Linux root arm64, or the one labelled cairn-root)
table=$(sfdisk --dump "$image" 2>/dev/null) || die "'$image' has no partition table sfdisk can read"
root_line=$(grep -i -E 'type=B921B045-1DF0-41C3-AF44-4C6F280D3FAE|name="cairn-root"' <<<"$table" | head -n 1 || true)
[[ -n "$root_line" ]] || die "'$image' has no root partition (type Linux root arm64 or name cairn-root): not made by make-image.sh?"
root_start=$(sed -nE 's/.*start= *([0-9]+).*/\1/p' <<<"$root_line")
grep -qi 'type=C12A7328-F81F-11D2-BA4B-00A0C93EC93B' <<<"$table" || die "'$image' has no EFI system partition"
# The image is checked before anything is installed or run as root.
[[ $(id -u) -eq 0 ]] || die "needs root (debugfs on the copy's root file system keeps file ownership as root)"

stage "host tools"
# shellcheck source=SCRIPTDIR/lib/apt.sh disable=SC1091
source "$here/scripts/lib/apt.sh"
apt_install_missing "$prog" qemu-system-arm qemu-efi-aarch64 e2fsprogs fdisk >/dev/null ||
  die "could not install qemu-system-arm qemu-efi-aarch64 e2fsprogs fdisk"
fw_code=/usr/share/AAVMF/AAVMF_CODE.fd fw_vars=/usr/share/AAVMF/AAVMF_VARS.fd
[[ -f $fw_code && -f $fw_vars ]] || die "no UEFI firmware at $fw_code (qemu-efi-aarch64)"

[[ -n "$work" ]] || work=/tmp/cairn-image/test.$$
mkdir -p "$work"
work=$(realpath "$work")
copy=$work/disk.raw vars=$work/vars.fd log=$work/console.log checks=$work/checks
[[ "$(realpath "$image")" != "$copy" ]] || die "the image is the test's own copy ($copy): give another --work-dir"
qemu_pid=""
cleanup() {
  if [[ -n "$qemu_pid" ]] && kill -0 "$qemu_pid" 2>/dev/null; then kill "$qemu_pid" 2>/dev/null || true; wait "$qemu_pid" 2>/dev/null || true; fi
  rm -rf "$checks"
  if ((keep)); then echo "$prog: kept $work (disk.raw, console.log)"; else rm -f "$copy" "$vars"; fi
}
trap cleanup EXIT

stage "copy of $image (the image is not touched)"
rm -f "$copy" "$log"
cp --sparse=always "$image" "$copy"
if [[ "$grow" != 0 ]]; then truncate -s "+$grow" "$copy"; fi
cp "$fw_vars" "$vars"

# ---- test-only files into the copy's root file system
mkdir -p "$checks"
cat >"$checks/cairn-image-test.service" <<'EOF'
# Test only (scripts/image-test.sh puts this into a copy of the image, never the image).
[Unit]
Description=Cairn image test: checks, then power off
After=multi-user.target

[Service]
# exec, not oneshot: the boot must be able to finish while the checks wait for it.
Type=exec
ExecStart=/usr/local/sbin/cairn-image-test
StandardOutput=journal+console
StandardError=journal+console
TimeoutStartSec=infinity
ExecStopPost=/bin/systemctl --no-block poweroff

[Install]
WantedBy=multi-user.target
EOF
cat >"$checks/cairn-image-test" <<'EOF'
#!/bin/bash
# Test only: runs inside the booted copy, prints CAIRN-CHECK lines on the console.
export SYSTEMD_PAGER='' SYSTEMD_COLORS=0 LC_ALL=C
pf() { if "$@"; then echo PASS; else echo FAIL; fi; }  # PASS if the command succeeds
check() { echo "CAIRN-CHECK $1 $2 ${3:-}"; }
prop() { systemctl show -p "$2" --value "$1"; }

echo "CAIRN-TEST begin"
state=$(systemctl is-system-running --wait 2>/dev/null)
check boot-finished "$([[ $state == running || $state == degraded ]] && echo PASS || echo FAIL)" "system state: $state"
if systemctl is-active -q multi-user.target; then check multi-user PASS "multi-user.target active"; else check multi-user FAIL "multi-user.target $(systemctl is-active multi-user.target)"; fi
echo "CAIRN-BOOT-TIME $(systemd-analyze time 2>&1 | tr '\n' ' ')"
mu=$(prop multi-user.target ActiveEnterTimestampMonotonic)
echo "CAIRN-MULTI-USER-US $mu"
# Expected to fail here: cairn-robot without the robot's devices (checked below), and
# waiting for a network that this guest does not have.
failed=$(systemctl list-units --failed --plain --no-legend | awk '{print $1}' |
  grep -v -x -e cairn-robot.service -e systemd-networkd-wait-online.service | tr '\n' ' ')
check no-failed-units "$([[ -z $failed ]] && echo PASS || echo FAIL)" "${failed:-none besides cairn-robot and networkd-wait-online (no network device)}"

# cairn-robot with the image's own configuration
en=$(systemctl is-enabled cairn-robot.service)
check robot-enabled "$(pf test "$en" = enabled)" "cairn-robot.service $en"
if out=$(cairn-robot --config /etc/cairn/robot.toml --check-config 2>&1); then
  check check-config PASS "$(echo "$out" | head -n 1)"
else
  check check-config FAIL "$(echo "$out" | tr '\n' ' ')"
fi
wd=$(prop cairn-robot.service WatchdogUSec)
check watchdog-configured "$([[ $wd == 5s ]] && echo PASS || echo FAIL)" "WatchdogUSec=$wd"
rtprio=$(prop cairn-robot.service LimitRTPRIO) memlock=$(prop cairn-robot.service LimitMEMLOCK)
check rt-limits-configured "$([[ $rtprio == 95 && $memlock == infinity ]] && echo PASS || echo FAIL)" "LimitRTPRIO=$rtprio LimitMEMLOCK=$memlock"
sleep 5  # let a failing start show its restart
inv=$(journalctl -b -u cairn-robot.service -o cat --no-pager 2>/dev/null)
starts=$(grep -c 'Starting cairn-robot.service\|Starting Cairn robot executive' <<<"$inv")
restarts=$(prop cairn-robot.service NRestarts)
active=$(prop cairn-robot.service ActiveState) sub=$(prop cairn-robot.service SubState)
why=$(grep -m1 -E 'cannot open|error' <<<"$inv" | cut -c1-200)
if grep -q '^\[devices\]' /etc/cairn/robot.toml; then
  # With [devices], cairn-robot needs the robot's CAN bus, laser and power board.
  if [[ $active == active ]]; then
    check robot-started PASS "active ($sub) with the image's configuration"
  elif ((starts >= 1)) && [[ -n $why ]] && ((restarts >= 1)); then
    check robot-started PASS "started by systemd $starts times (NRestarts=$restarts), stops without the robot's hardware, as it must: $why"
  else
    check robot-started FAIL "ActiveState=$active SubState=$sub starts=$starts NRestarts=$restarts: $(tail -n 3 <<<"$inv" | tr '\n' ' ')"
  fi
else
  check robot-started "$(pf test "$active" = active)" "ActiveState=$active SubState=$sub: $(tail -n 3 <<<"$inv" | tr '\n' ' ')"
fi

# cairn-robot run by systemd with the same configuration minus [devices]: status only, on
# the guest's loopback. A runtime drop-in (in /run), so the image's unit is what runs.
awk '/^\[/{skip=($0 ~ /^\[devices\]/)} !skip' /etc/cairn/robot.toml >/run/cairn-robot-status-only.toml
mkdir -p /run/systemd/system/cairn-robot.service.d
cat >/run/systemd/system/cairn-robot.service.d/image-test.conf <<'UNIT'
[Service]
ExecStartPre=
ExecStartPre=/usr/bin/cairn-robot --config /run/cairn-robot-status-only.toml --check-config
ExecStart=
ExecStart=/usr/bin/cairn-robot --config /run/cairn-robot-status-only.toml
UNIT
systemctl daemon-reload
systemctl reset-failed cairn-robot.service
if timeout 120 systemctl restart cairn-robot.service; then
  check status-only-ready PASS "READY=1 received: $(prop cairn-robot.service StatusText | cut -c1-120)"
else
  check status-only-ready FAIL "$(journalctl -b -u cairn-robot.service -o cat -n 5 --no-pager | tr '\n' ' ')"
fi
w1=$(prop cairn-robot.service WatchdogTimestampMonotonic)
sleep 8
w2=$(prop cairn-robot.service WatchdogTimestampMonotonic)
if [[ $(prop cairn-robot.service ActiveState) == active && ${w1:-0} -gt 0 && ${w2:-0} -gt ${w1:-0} ]]; then
  check watchdog-fed PASS "pings 8 s apart: WatchdogTimestampMonotonic $w1 -> $w2 us, still active"
else
  check watchdog-fed FAIL "ActiveState=$(prop cairn-robot.service ActiveState) WatchdogTimestampMonotonic $w1 -> $w2"
fi
pid=$(prop cairn-robot.service MainPID)
rt=$(awk '/^Max realtime priority/{print $4}' "/proc/$pid/limits" 2>/dev/null)  # the soft limit
ml=$(awk '/^Max locked memory/{print $4}' "/proc/$pid/limits" 2>/dev/null)
user=$(ps -o user= -p "$pid" 2>/dev/null)
check rt-limits-applied "$([[ $rt == 95 && $ml == unlimited && $user == cairn ]] && echo PASS || echo FAIL)" "pid $pid user ${user:-?}: max realtime priority ${rt:-?}, max locked memory ${ml:-?}"
systemctl stop cairn-robot.service
rm -rf /run/systemd/system/cairn-robot.service.d; systemctl daemon-reload

# SSH, identity, first boot
sa=$(systemctl is-active ssh.service)
check sshd "$(pf test "$sa" = active)" "ssh.service $sa"
cfg=$(sshd -T 2>/dev/null)
pa=$(awk '$1=="passwordauthentication"{print $2}' <<<"$cfg") prl=$(awk '$1=="permitrootlogin"{print $2}' <<<"$cfg")
check ssh-keys-only "$([[ $pa == no && $prl == without-password ]] && echo PASS || echo FAIL)" "passwordauthentication $pa, permitrootlogin $prl, $(grep -c . /root/.ssh/authorized_keys 2>/dev/null) authorized key(s)"
check ssh-host-keys "$(pf test -s /etc/ssh/ssh_host_ed25519_key)" "made at first boot: $(ssh-keygen -lf /etc/ssh/ssh_host_ed25519_key.pub 2>&1 | cut -d' ' -f2)"
check hostname "$([[ $(hostname) == "$(cat /etc/hostname)" ]] && echo PASS || echo FAIL)" "$(hostname)"
check machine-id "$(pf test -s /etc/machine-id)" "made at first boot: $(cat /etc/machine-id)"
ifs=$(find /sys/class/net -mindepth 1 -maxdepth 1 -printf '%f ' | sed 's/ $//')
check loopback-only "$(pf test "$ifs" = lo)" "network interfaces: $ifs (qemu -nic none: DDS cannot leave the guest)"
rootdev=$(readlink -f "$(findmnt -no SOURCE /)")
fs_k=$(tune2fs -l "$rootdev" 2>/dev/null | awk '/^Block count:/{c=$3} /^Block size:/{b=$3} END{print int(c*b/1024)}')
part_k=$(( $(cat "/sys/class/block/$(basename "$rootdev")/size") / 2 ))
echo "CAIRN-ROOT-FS $rootdev: partition ${part_k} KiB, ext4 ${fs_k} KiB, $(df -h --output=used / | tail -n 1 | tr -d ' ') used"
echo "CAIRN-ROOT-FS-KIB ${fs_k}"
echo "CAIRN-TEST end"
EOF
chmod 0755 "$checks/cairn-image-test"
img_dev="$copy?offset=$((root_start * 512))"
debugfs -w -f - "$img_dev" >"$work/debugfs.log" 2>&1 <<EOF || die "debugfs on the copy failed ($work/debugfs.log)"
cd /usr/local/sbin
write $checks/cairn-image-test cairn-image-test
cd /etc/systemd/system
write $checks/cairn-image-test.service cairn-image-test.service
cd /etc/systemd/system/multi-user.target.wants
symlink cairn-image-test.service /etc/systemd/system/cairn-image-test.service
EOF
grep -qi 'error\|not found\|could not' "$work/debugfs.log" && die "debugfs: $(grep -i -m1 'error\|not found\|could not' "$work/debugfs.log")"
debugfs -R "stat /usr/local/sbin/cairn-image-test" "$img_dev" 2>/dev/null | grep -q 'Mode:  0755' ||
  die "the test script did not land in the copy with mode 0755"
expected_root_k=$(( ($(stat -c %s "$copy") / 512 - root_start - 34) / 2 ))

# ---- boot
stage "booting the copy: qemu-system-aarch64 -M virt -cpu $cpu -smp $smp, TCG, UEFI, no network (log: $log)"
qemu-system-aarch64 -M virt -cpu "$cpu" -smp "$smp" -m 1024 -accel tcg \
  -drive if=pflash,format=raw,readonly=on,file="$fw_code" -drive if=pflash,format=raw,file="$vars" \
  -drive if=virtio,format=raw,file="$copy" -device virtio-rng-pci \
  -nic none -display none -monitor none -serial file:"$log" -no-reboot &
qemu_pid=$!
boot_start=$SECONDS
seen_grub=0 seen_kernel=0
while kill -0 "$qemu_pid" 2>/dev/null; do
  if ((SECONDS - boot_start > timeout)); then
    kill "$qemu_pid" 2>/dev/null || true; wait "$qemu_pid" 2>/dev/null || true; qemu_pid=""
    echo "$prog: TIMEOUT: the guest did not finish its checks within $timeout s. Console log tail ($log):" >&2
    tr -d '\r' <"$log" | sed 's/\x1b\[[0-9;]*[A-Za-z]//g' | tail -n 20 | cut -c1-160 | sed 's/^/  | /' >&2
    keep=1
    exit 1
  fi
  if ((!seen_grub)) && grep -q 'Booting\|GNU GRUB\|EFI stub' "$log" 2>/dev/null; then seen_grub=1; stage "firmware handed over to GRUB/the kernel"; fi
  if ((!seen_kernel)) && grep -qa 'Linux version' "$log" 2>/dev/null; then seen_kernel=1; stage "kernel booting"; fi
  sleep 2
done
wait "$qemu_pid" || true
qemu_pid=""
run_s=$((SECONDS - boot_start))
stage "guest powered off after $run_s s"

# ---- results
tr -d '\r' <"$log" >"$log.txt"
grep -q 'CAIRN-TEST end' "$log.txt" || { keep=1; echo "$prog: the guest stopped before its checks ended; console log tail:" >&2; sed 's/\x1b\[[0-9;]*[A-Za-z]//g' "$log.txt" | tail -n 20 | cut -c1-160 | sed 's/^/  | /' >&2; exit 1; }
echo "$prog: boot: $(sed -n 's/.*CAIRN-BOOT-TIME //p' "$log.txt" | head -n 1)"
mu_us=$(sed -n 's/.*CAIRN-MULTI-USER-US \([0-9]*\).*/\1/p' "$log.txt" | head -n 1)
[[ -n $mu_us ]] && echo "$prog: multi-user.target reached $((mu_us / 1000000)).$(printf '%01d' $((mu_us / 100000 % 10))) s after the kernel started (UEFI firmware and GRUB before it: see the log)"
fails=0 n=0
while read -r _ name result detail; do
  n=$((n + 1))
  printf '%s: %-22s %s  %s\n' "$prog" "$name" "$result" "$detail"
  [[ $result == PASS ]] || fails=$((fails + 1))
done < <(grep -a 'CAIRN-CHECK ' "$log.txt" | sed 's/.*CAIRN-CHECK /CAIRN-CHECK /')
sed -n 's/.*CAIRN-ROOT-FS /image-test: root: /p' "$log.txt" | head -n 1
if [[ "$grow" != 0 ]]; then
  got_k=$(sed -n 's/.*CAIRN-ROOT-FS-KIB //p' "$log.txt" | head -n 1)
  n=$((n + 1))
  # ext4 reserves some blocks for itself: within 2 % of the partition's size counts as grown.
  if [[ -n $got_k ]] && ((got_k * 100 >= expected_root_k * 98)); then
    printf '%s: %-22s PASS  %s\n' "$prog" root-grown "the root file system fills the larger card: $got_k of $expected_root_k KiB"
  else
    printf '%s: %-22s FAIL  %s\n' "$prog" root-grown "root file system ${got_k:-?} KiB, the card leaves $expected_root_k KiB"
    fails=$((fails + 1))
  fi
fi
((n >= 10)) || { echo "$prog: only $n checks reported (expected at least 10): see $log.txt" >&2; keep=1; exit 1; }
if ((fails)); then echo "$prog: $fails of $n checks FAILED (console log: $log.txt)"; keep=1; exit 1; fi
echo "$prog: all $n checks passed (guest ran $run_s s from power-on to power-off)"
