#!/usr/bin/env bash
# scripts/flash.sh on loop devices the test makes (never a real disk): it writes and
# verifies an image, asks first and stops on a wrong answer, and refuses what it must
# refuse (a mounted device, also at a path with a space or in another mount namespace,
# active swap, the system's disk, a partition, a read-only or too large or too small
# device, a missing, empty, compressed or table-less image), writing nothing then.
# --verify-only finds a byte changed on the card. Needs root and loop devices (losetup).
#   flash_test.sh SOURCE_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
flash="$src/scripts/flash.sh"
work=$(mktemp -d)
loops=()
made_node="" holder_pid="" swap_on=""
cleanup() {
  set +e  # every step, whatever fails
  [[ -n "$holder_pid" ]] && kill "$holder_pid" 2>/dev/null && wait "$holder_pid" 2>/dev/null
  for m in "$work/mnt" "$work/mount point" "$work/ns"; do mountpoint -q "$m" 2>/dev/null && { umount "$m" || umount -l "$m"; }; done
  [[ -n "$swap_on" ]] && swapoff "$swap_on"
  for l in "${loops[@]}"; do losetup -d "$l" 2>/dev/null || true; done
  [[ -n "$made_node" ]] && rm -f "$made_node"
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pass() { echo "ok: $*"; }
attach() {  # FILE [losetup options...]: attaches it, the device in $attached
  attached=$(losetup -f --show "$@") || fail "losetup $* failed (needs root and loop devices)"
  loops+=("$attached")
}
sum_of() { head -c "$2" "$1" | sha256sum | cut -d' ' -f1; }

# An 8 MiB image: a DOS partition table with one Linux partition, random bytes in it.
img="$work/robot.img"
truncate -s 8M "$img"
echo 'start=2048, type=83' | sfdisk -q "$img" >/dev/null
dd if=/dev/urandom of="$img" bs=1M seek=1 count=7 conv=notrunc status=none
img_bytes=$(stat -c %s "$img")

# The card: 24 MiB of zeros behind a loop device with partition scanning.
card="$work/card.bin"
truncate -s 24M "$card"
attach -P "$card"
dev=$attached
zeros=$(sum_of "$dev" "$img_bytes")

expect_refusal() {  # WHAT PATTERN FLASH-ARGS... : exit 1, the message matches, the card unchanged
  local what=$1 pattern=$2 out rc=0 before
  shift 2
  before=$(sum_of "$card" 16777216)
  out=$("$flash" "$@" 2>&1 </dev/null) || rc=$?
  ((rc == 1)) || fail "$what: exit $rc, expected 1; output: $out"
  [[ "$out" =~ $pattern ]] || fail "$what: message does not match /$pattern/: $out"
  [[ "$(sum_of "$card" 16777216)" == "$before" ]] || fail "$what: the card changed"
  pass "$what refused: $(echo "$out" | tail -n1)"
}

# --- Asks, and a wrong answer writes nothing.
out=$(echo no | "$flash" --image "$img" --device "$dev" 2>&1) && fail "a wrong answer went on: $out"
[[ "$out" == *"aborted: nothing written"* ]] || fail "no abort message: $out"
[[ "$out" == *"about to overwrite $dev"* && "$out" == *"will be lost"* ]] || fail "did not show the device: $out"
[[ "$(sum_of "$dev" "$img_bytes")" == "$zeros" ]] || fail "the card changed after 'no'"
pass "asks, and 'no' writes nothing"

# --- Typing the device name writes it, verified.
out=$(echo "$dev" | "$flash" --image "$img" --device "$dev" 2>&1) || fail "flash failed: $out"
[[ "$out" == *"verified"* ]] || fail "no verification reported: $out"
cmp -n "$img_bytes" "$img" "$dev" || fail "the card does not hold the image"
[[ "$(tail -c +$((img_bytes + 1)) "$card" | tr -d '\0' | wc -c)" == 0 ]] || fail "bytes after the image were touched"
pass "typing the device name writes and verifies the image"

# --- --verify-only: equal now; one byte changed on the card is found, with its offset.
"$flash" --verify-only --image "$img" --device "$dev" >/dev/null 2>&1 || fail "--verify-only failed on an intact card"
# The complement of the image's byte there: a changed byte whatever the random image holds.
byte=$(od -An -tu1 -j 3000000 -N 1 "$img" | tr -d ' ')
printf "\\$(printf '%03o' $((255 - byte)))" | dd of="$dev" bs=1 seek=3000000 conv=notrunc,fsync status=none
rc=0
out=$("$flash" --verify-only --image "$img" --device "$dev" 2>&1) || rc=$?
((rc == 4)) || fail "--verify-only on a changed card: exit $rc, expected 4: $out"
[[ "$out" == *"differs from the image at byte 3000001 "* ]] || fail "the changed byte is not reported: $out"
pass "--verify-only finds the changed byte: $(echo "$out" | tail -n1)"

# --- --yes writes without asking (and repairs the card).
out=$("$flash" --image "$img" --device "$dev" --yes 2>&1 </dev/null) || fail "--yes failed: $out"
cmp -n "$img_bytes" "$img" "$dev" || fail "--yes: the card does not hold the image"
pass "--yes writes without asking"

# --- Refusals (the card holds the image now; each must leave it as it is).
part="${dev}p1"
if [[ ! -b "$part" && -r "/sys/class/block/${part#/dev/}/dev" ]]; then  # no udev here: make the node
  IFS=: read -r major minor <"/sys/class/block/${part#/dev/}/dev"
  mknod "$part" b "$major" "$minor" 2>/dev/null && made_node="$part"  # (udev may have made it meanwhile)
fi
[[ -b "$part" ]] || fail "no partition device $part after writing the image"
expect_refusal "a partition" "is a partition: give the whole disk \(${dev}\)" --image "$img" --device "$part" --yes

mkfs.ext4 -q -F "$part"
mkdir -p "$work/mnt"
mount "$part" "$work/mnt"
expect_refusal "a mounted device" "in use: ${part} on $work/mnt; unmount it first: umount \"$work/mnt\"" --image "$img" --device "$dev" --yes
CAIRN_FLASH_SYSTEM_MOUNTS="$work/mnt" expect_refusal "the system's disk" "holds the running system" \
  --image "$img" --device "$dev" --yes
umount "$work/mnt"
mkdir -p "$work/mount point"
mount "$part" "$work/mount point"
expect_refusal "a device mounted at a path with a space" "umount \"$work/mount point\"" --image "$img" --device "$dev" --yes
umount "$work/mount point"

# Mounted in another mount namespace: invisible to this one's lsblk and findmnt (as from a
# chroot or container); the kernel's exclusive open still refuses.
# The mount point lies in a private tmpfs of the test's, so a mount made under it in the new
# namespace does not propagate back (unshare's own --propagation needs / to be a mount
# point, which it is not in a chroot).
mkdir -p "$work/ns"
mount -t tmpfs cairn-flash-test "$work/ns"
mount --make-private "$work/ns"
mkdir -p "$work/ns/elsewhere"
unshare -m --propagation unchanged sh -c "mount '$part' '$work/ns/elsewhere' && touch '$work/held' && exec sleep 60" &
holder_pid=$!
for _ in $(seq 1 100); do [[ -e "$work/held" ]] && break; sleep 0.05; done
[[ -e "$work/held" ]] || fail "could not mount the partition in another mount namespace"
[[ -z "$(lsblk -nrpo MOUNTPOINT "$dev" | awk NF)" ]] || fail "the other namespace's mount is visible here"
expect_refusal "a device mounted in another mount namespace" "refuses an exclusive open" --image "$img" --device "$dev" --yes
kill "$holder_pid"; wait "$holder_pid" 2>/dev/null || true; holder_pid=""
umount "$work/ns"

mkswap -q "$part" >/dev/null
if swapon "$part" 2>/dev/null; then
  swap_on=$part
  expect_refusal "a device with active swap" "swap on ${part}; swapoff ${part} first" --image "$img" --device "$dev" --yes
  swapoff "$part"; swap_on=""
else
  echo "note: swapon refused here (no swap support): the swap case is not checked"
fi

expect_refusal "a device over --max-size" "larger than --max-size 16M.*--allow-large" \
  --image "$img" --device "$dev" --yes --max-size 16M
out=$("$flash" --image "$img" --device "$dev" --yes --max-size 16M --allow-large 2>&1) || fail "--allow-large failed: $out"
pass "--allow-large writes to a device over --max-size"

big="$work/big.img"
truncate -s 32M "$big"
echo 'start=2048, type=83' | sfdisk -q "$big" >/dev/null
expect_refusal "an image larger than the device" "smaller than the image" --image "$big" --device "$dev" --yes

attach -r "$card"
ro=$attached
expect_refusal "a read-only device" "is read-only" --image "$img" --device "$ro" --yes

expect_refusal "a regular file as device" "is not a block device" --image "$img" --device "$card" --yes
expect_refusal "a missing device" "does not exist" --image "$img" --device /dev/cairn-no-such-disk --yes
expect_refusal "a missing image" "does not exist" --image "$work/none.img" --device "$dev" --yes
head -c 1M /dev/urandom >"$work/noise.img"
printf '\x00\x00' | dd of="$work/noise.img" bs=1 seek=510 conv=notrunc status=none
expect_refusal "an image without a partition table" "no partition table" --image "$work/noise.img" --device "$dev" --yes
xz -k -0 -c "$img" >"$work/robot.img.xz"
expect_refusal "a compressed image" "xz-compressed: decompress it first" --image "$work/robot.img.xz" --device "$dev" --yes
gzip -c "$img" >"$work/robot.img.gz"
expect_refusal "a gzip image" "gzip-compressed" --image "$work/robot.img.gz" --device "$dev" --yes
: >"$work/empty.img"
expect_refusal "an empty image" "is empty" --image "$work/empty.img" --device "$dev" --yes
head -c 1000 "$img" >"$work/short.img"
expect_refusal "an image of part of a sector" "not whole 512-byte sectors" --image "$work/short.img" --device "$dev" --yes

# A /dev/disk/by-id style link to the card is followed, and the card written.
ln -s "$dev" "$work/by-id-card"
out=$("$flash" --image "$img" --device "$work/by-id-card" --yes 2>&1 </dev/null) || fail "through a link: $out"
[[ "$out" == *"verified"*"$dev"* || "$out" == *"$dev"*"verified"* ]] || fail "the link was not resolved to $dev: $out"
pass "a link to the card is resolved and written"

# Usage errors: exit 2.
rc=0; "$flash" --image "$img" >/dev/null 2>&1 || rc=$?
((rc == 2)) || fail "no --device: exit $rc, expected 2"
rc=0; "$flash" --image "$img" --device "$dev" --max-size lots >/dev/null 2>&1 || rc=$?
((rc == 2)) || fail "--max-size lots: exit $rc, expected 2"
rc=0; "$flash" --device "$dev" --image >/dev/null 2>&1 || rc=$?
((rc == 2)) || fail "--image without a value: exit $rc, expected 2"
out=$("$flash" --image "$img" --device "$dev" --yes --max-size 08M 2>&1 </dev/null) && fail "--max-size 08M wrote to a 24 MiB card"
[[ "$out" == *"larger than --max-size 08M"* ]] || fail "--max-size 08M not read as 8 MiB: $out"
pass "usage errors exit 2"
echo "flash_test: all passed"
