#!/usr/bin/env bash
# Writes a robot disk image to a card or disk (an SD card, an eMMC module in a USB
# reader), safely, and checks what it wrote by reading it back (docs/flashing.md).
#
#   scripts/flash.sh --image robot.img --device /dev/sdX [options]
#
#   --image FILE       the raw disk image (not compressed: xz -dk robot.img.xz first)
#   --device DEV       the whole card or disk (/dev/sdX, /dev/mmcblkN), never a partition
#   --yes              do not ask (for scripts); every refusal below still applies
#   --max-size SIZE    refuse a device larger than this (default 128G: a robot's card or
#                      eMMC; a larger device is more likely a backup or system disk);
#                      suffixes K, M, G, T (powers of 1024)
#   --allow-large      write to a device larger than --max-size anyway
#   --verify-only      write nothing: compare the device's first bytes with the image
#
# Refuses, before writing anything: a device that is not a block device, is a partition,
# is read-only, is (or holds) the disk the running system is on, has a mounted file system
# or active swap on it or on one of its partitions, is held by the kernel for anything
# else (an exclusive open fails: mounted in another mount namespace, an LVM, RAID, LUKS or
# btrfs member), is smaller than the image, or is larger than --max-size; an image that is
# missing, empty, compressed or has no partition table. Shows the device (model, size,
# partitions) and asks for its name to be typed back; then checks it is still the same
# device. Writes with dd through an exclusive open held for the whole write (progress on
# stderr), flushes, drops the device's cached pages, then reads it back and compares it
# with the image byte for byte.
# Exit status: 0 written and verified; 1 refused or aborted (nothing written); 2 a usage
# error; 3 the write failed; 4 the read-back differs from the image.
set -euo pipefail

prog=flash
die() { echo "$prog: $1" >&2; exit "${2:-1}"; }  # MESSAGE [EXIT-STATUS]
usage() { sed -n '2,26p' "$0"; }

image="" device="" yes=0 max_size=128G allow_large=0 verify_only=0
value() { [[ $# -ge 2 && -n "$2" ]] || { echo "$prog: $1 needs a value (try --help)" >&2; exit 2; }; }
while (($#)); do
  case "$1" in
    --image) value "$@"; image=$2; shift 2 ;;
    --device) value "$@"; device=$2; shift 2 ;;
    --yes) yes=1; shift ;;
    --max-size) value "$@"; max_size=$2; shift 2 ;;
    --allow-large) allow_large=1; shift ;;
    --verify-only) verify_only=1; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "$prog: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
[[ -n "$image" ]] || { echo "$prog: --image is required (try --help)" >&2; exit 2; }
[[ -n "$device" ]] || { echo "$prog: --device is required (try --help)" >&2; exit 2; }

bytes_of() {  # SIZE with an optional K/M/G/T suffix -> bytes
  local v=$1 n unit
  [[ "$v" =~ ^([0-9]+)([KMGT]?)i?B?$ ]] || die "--max-size '$v': expected a number with an optional K, M, G or T" 2
  n=$((10#${BASH_REMATCH[1]})) unit=${BASH_REMATCH[2]}
  case "$unit" in
    K) echo $((n << 10)) ;; M) echo $((n << 20)) ;; G) echo $((n << 30)) ;; T) echo $((n << 40)) ;; *) echo "$n" ;;
  esac
}
human() { numfmt --to=iec-i --suffix=B "$1"; }
max_bytes=$(bytes_of "$max_size")

# --- The image.
[[ -e "$image" ]] || die "image '$image' does not exist"
[[ -f "$image" ]] || die "image '$image' is not a regular file"
[[ -r "$image" ]] || die "image '$image' is not readable"
image_bytes=$(stat -c %s "$image")
((image_bytes > 0)) || die "image '$image' is empty"
magic=$(head -c 6 "$image" | od -An -tx1 | tr -d ' \n')
case "$magic" in
  fd377a585a00*) die "image '$image' is xz-compressed: decompress it first (xz -dk '$image')" ;;
  28b52ffd*) die "image '$image' is zstd-compressed: decompress it first (zstd -d '$image')" ;;
  1f8b*) die "image '$image' is gzip-compressed: decompress it first (gunzip -k '$image')" ;;
esac
((image_bytes % 512 == 0)) || die "image '$image' is $image_bytes bytes, not whole 512-byte sectors: not a disk image"
# An MBR, or GPT's protective MBR, ends its first sector with 55 AA.
[[ "$(dd if="$image" bs=1 skip=510 count=2 status=none | od -An -tx1 | tr -d ' \n')" == "55aa" ]] ||
  die "image '$image' has no partition table (no 55 AA at byte 510): not a disk image"

# --- The device.
[[ -e "$device" ]] || die "device '$device' does not exist"
[[ -b "$device" ]] || die "device '$device' is not a block device"
device=$(readlink -f "$device")
type=$(lsblk -dno TYPE "$device" 2>/dev/null | head -n1) || true
case "$type" in
  disk|loop) ;;
  part) die "device '$device' is a partition: give the whole disk ($(lsblk -dno PKNAME "$device" | head -n1 | sed 's|^|/dev/|'))" ;;
  *) die "device '$device' is a '${type:-unknown}' device, not a disk: refusing (a card or disk is 'disk' in lsblk)" ;;
esac
((verify_only)) || [[ "$(blockdev --getro "$device")" == 0 ]] || die "device '$device' is read-only (a card's lock switch?)"

# The disks under the running system: what its system mounts live on, followed down
# through partitions, LVM, LUKS and RAID (lsblk -s lists a device and what it is built on).
# Without a mount table every check below would pass blind: refuse instead.
# (In a chroot "/" need not be a mount point: the table is only required to be readable.)
[[ -n "$(head -c 1 /proc/self/mountinfo 2>/dev/null)" ]] ||
  die "cannot read the mount table (/proc/self/mountinfo; is /proc mounted?): refusing to guess which disks are in use"
system_mounts="/ /boot /boot/efi /usr /var /home ${CAIRN_FLASH_SYSTEM_MOUNTS:-}"  # a test adds its own
system_disks=()
add_disks_under() {  # DEVICE: the disk(s) it is built on
  local name t
  while read -r name t; do
    [[ "$t" == disk || "$t" == loop ]] && system_disks+=("$name")
  done < <(lsblk -nrpso NAME,TYPE "$1" 2>/dev/null || true)
}
for m in $system_mounts; do
  src=$(findmnt -nfo SOURCE --mountpoint "$m" 2>/dev/null || true)  # not a mount point: nothing to add
  [[ "$src" == /dev/* ]] && add_disks_under "${src%%[*}"
done
for d in "${system_disks[@]}"; do
  [[ "$(readlink -f "$d")" == "$device" ]] && die "device '$device' holds the running system (one of the mounts $system_mounts): refusing"
done

# Mounted file systems and active swap on the device or any of its partitions.
# (lsblk -r writes a space in a mount point as \x20: printf %b turns it back for the message.)
tree=$(lsblk -nrpo NAME,MOUNTPOINT "$device") || die "lsblk cannot list '$device'"
swaps=$(awk 'NF > 1 && $2 == "[SWAP]" {print $1}' <<<"$tree")
[[ -z "$swaps" ]] || die "device '$device' is in use: swap on $(paste -sd ' ' <<<"$swaps"); swapoff $(paste -sd ' ' <<<"$swaps") first"
mounted=$(awk 'NF > 1 {print $1 " on " $2}' <<<"$tree")
if [[ -n "$mounted" ]]; then
  points=$(awk 'NF > 1 {printf "%s\"%s\"", sep, $2; sep = " "}' <<<"$tree")
  die "device '$device' is in use: $(printf '%b' "$(paste -sd ';' <<<"$mounted" | sed 's/;/; /g')"); unmount it first: umount $(printf '%b' "$points")"
fi
# What the mount table cannot show (another mount namespace, a container; LVM, RAID, LUKS,
# btrfs or ZFS members): the kernel refuses an exclusive open of a block device in use.
exclusive_ok() { perl -MFcntl -e 'sysopen(my $f, $ARGV[0], O_RDONLY | O_EXCL) or exit 1' "$1"; }
exclusive_ok "$device" ||
  die "device '$device' is in use: the kernel refuses an exclusive open (a file system mounted elsewhere, in another namespace or container, or a member of LVM, RAID, LUKS, btrfs or ZFS)"
holders=$(shopt -s nullglob
  for h in /sys/class/block/"${device#/dev/}"/holders/* /sys/class/block/"${device#/dev/}"/*/holders/*; do
    basename "$h"
  done | sort -u | paste -sd ' ')
[[ -z "$holders" ]] || die "device '$device' is in use: held by $holders (device-mapper or RAID)"

device_bytes=$(blockdev --getsize64 "$device")
((device_bytes >= image_bytes)) ||
  die "device '$device' ($(human "$device_bytes")) is smaller than the image ($(human "$image_bytes"))"
if ((device_bytes > max_bytes)) && ((!allow_large)) && ((!verify_only)); then
  die "device '$device' is $(human "$device_bytes"), larger than --max-size $max_size: is it really the robot's card? (--allow-large writes anyway)"
fi

verify() {
  echo "$prog: reading $(human "$image_bytes") back from $device"
  blockdev --flushbufs "$device" || die "cannot flush $device's cached pages (blockdev --flushbufs): not verified" 4
  local out rc=0
  # --flushbufs also drops the device's cached pages: what is read next comes from the medium.
  out=$(dd if="$device" bs=4M iflag=count_bytes count="$image_bytes" status=progress | cmp - "$image" 2>&1) || rc=$?
  if ((rc != 0)); then
    [[ "$out" == *EOF* ]] && die "verify failed: $device returned fewer bytes than the image ($out)" 4
    # cmp says "byte N" or, in the C locale, "char N" (counting from 1).
    local at
    at=$(grep -oE '(byte|char) [0-9]+' <<<"$out" | grep -oE '[0-9]+' | head -n1) || true
    die "verify failed: $device differs from the image at byte ${at:-?} (counting from 1; cmp: $out)" 4
  fi
  echo "$prog: verified: the first $(human "$image_bytes") of $device equal $image"
}

if ((verify_only)); then
  verify
  exit 0
fi

identity() { echo "$(stat -Lc '%t:%T' "$device" 2>/dev/null) $(blockdev --getsize64 "$device" 2>/dev/null) $(lsblk -dno SERIAL "$device" 2>/dev/null)"; }
shown=$(identity)

# --- Show and ask.
echo "$prog: about to overwrite $device with $image ($(human "$image_bytes")):"
lsblk -o NAME,SIZE,TYPE,MODEL,SERIAL,TRAN,FSTYPE,LABEL "$device" | sed 's/^/  /'
echo "$prog: everything on $device ($(human "$device_bytes")) will be lost."
if ((!yes)); then
  printf '%s: type the device name (%s) to write, anything else to stop: ' "$prog" "$device"
  answer=""
  read -r answer || true
  [[ "$answer" == "$device" ]] || die "aborted: nothing written"
  # Minutes may have passed: the same card (numbers, size, serial), still not in use.
  [[ "$(identity)" == "$shown" ]] || die "device '$device' changed while waiting for the answer (another card?): nothing written; run again"
  tree=$(lsblk -nrpo NAME,MOUNTPOINT "$device") || die "lsblk cannot list '$device'"
  [[ -z "$(awk 'NF > 1' <<<"$tree")" ]] || die "device '$device' was mounted while waiting for the answer: nothing written; unmount it and run again"
fi

# --- Write.
start=${EPOCHREALTIME/[.,]/}
echo "$prog: writing"
# dd writes to an exclusive descriptor held for the whole write: nothing can mount or claim
# the device meanwhile, and if something did since the checks, the open fails (EBUSY).
if ! perl -MFcntl -e 'sysopen(my $f, shift, O_WRONLY | O_EXCL) or die "cannot open it exclusively: $!\n";
                      open(STDOUT, ">&", $f) or die "$!\n"; exec @ARGV or die "$!\n"' \
     "$device" dd if="$image" bs=4M iflag=fullblock conv=fsync status=progress; then
  die "writing $device failed (see the message above); the card may be partly written" 3
fi
ms=$(( (${EPOCHREALTIME/[.,]/} - start) / 1000 ))
echo "$prog: wrote $(human "$image_bytes") in $((ms / 1000)).$(( (ms % 1000) / 100 )) s"
verify
# Let the kernel see the new partition table (a card reader may need a re-plug instead).
partx -u "$device" 2>/dev/null || blockdev --rereadpt "$device" 2>/dev/null ||
  echo "$prog: note: the kernel did not re-read the partition table; re-plug the card to see it"
echo "$prog: done: $device holds $image"
