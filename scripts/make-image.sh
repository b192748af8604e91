#!/usr/bin/env bash
# Builds a bootable Debian bookworm disk image for a robot computer, with cairn-robot
# installed, configured and enabled (docs/robot-image.md). Only Debian packages go in.
#
#   scripts/make-image.sh aarch64 --out robot.img [options]
#
#   aarch64                 the target (arm64). armhf is not built: see docs/robot-image.md
#   --out FILE              the raw disk image to write (required; replaced if it exists)
#   --package FILE.deb      the cairn-robot arm64 package (default: the newest
#                           build/aarch64/packages/cairn-robot_*_arm64.deb, from
#                           scripts/package.sh aarch64)
#   --config FILE.toml      the robot's configuration, becomes /etc/cairn/robot.toml
#                           (default: the package's example configuration)
#   --dds-profile FILE.xml  a Cyclone DDS profile, becomes /etc/cairn/dds.xml; the
#                           configuration must then say  [dds] profile = "/etc/cairn/dds.xml"
#   --keys DIR              the robot's DDS Security keys (scripts/fleet-keys.sh add FLEET robot ID
#                           made DIR = FLEET/members/robot-ID), become /etc/cairn/keys readable by
#                           the service user only; needs a --config with [dds] profile = "secure"
#                           and keys = "/etc/cairn/keys". Refused unless they are that robot's and
#                           verify against their CA and revocation list (docs/security.md)
#   --hostname NAME         (default: the configuration's [robot] name, else cairn-robot)
#   --ssh-key FILE.pub      a public key allowed to log in as root over SSH (repeatable).
#                           Password logins are off, root has no password: without a key
#                           nobody can log in (a warning says so)
#   --size SIZE             the image's size, e.g. 2G, 1536M (default 2G); the root file
#                           system grows to fill the card at first boot
#   --mirror URL            Debian mirror (default http://deb.debian.org/debian)
#   --work-dir DIR          scratch space (default /tmp/cairn-image/work.PID, removed after)
#   --apt-cache DIR         keep the downloaded .debs here and reuse them next time
#
# Layout: GPT; partition 1 an EFI system partition (FAT32, 256 MiB, GRUB as the removable
# path EFI/BOOT/BOOTAA64.EFI), partition 2 the ext4 root (label cairn-root, found by
# PARTUUID). Assembled without loop devices or mounts: mmdebstrap into a directory,
# mkfs.ext4 -d, mkfs.vfat + mcopy, sfdisk and dd on the image file.
# Needs root (mmdebstrap's root mode, file ownership in the root file system) and
# binfmt_misc with qemu-aarch64 (mounted and registered here when missing).
# Exit status: 0 built; 1 a failure (the message says which stage); 2 a usage error.
set -euo pipefail

prog=make-image
here=$(cd "$(dirname "$0")/.." && pwd)
die() { echo "$prog: $1" >&2; exit "${2:-1}"; }  # MESSAGE [EXIT-STATUS]
usage() { sed -n '2,34p' "$0"; }
t0=$SECONDS
stage() { echo "$prog: [$((SECONDS - t0)) s] $*"; }

# ---- arguments
target="" out="" package="" config="" dds_profile="" keys="" hostname="" size=2G work="" apt_cache=""
mirror=http://deb.debian.org/debian
ssh_keys=()
value() { [[ $# -ge 2 && -n "$2" ]] || { echo "$prog: $1 needs a value (try --help)" >&2; exit 2; }; }
while (($#)); do
  case "$1" in
    --out) value "$@"; out=$2; shift 2 ;;
    --package) value "$@"; package=$2; shift 2 ;;
    --config) value "$@"; config=$2; shift 2 ;;
    --dds-profile) value "$@"; dds_profile=$2; shift 2 ;;
    --keys) value "$@"; keys=$2; shift 2 ;;
    --hostname) value "$@"; hostname=$2; shift 2 ;;
    --ssh-key) value "$@"; ssh_keys+=("$2"); shift 2 ;;
    --size) value "$@"; size=$2; shift 2 ;;
    --mirror) value "$@"; mirror=$2; shift 2 ;;
    --work-dir) value "$@"; work=$2; shift 2 ;;
    --apt-cache) value "$@"; apt_cache=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "$prog: unknown option '$1' (try --help)" >&2; exit 2 ;;
    *) [[ -z "$target" ]] || { echo "$prog: one target only, got '$target' and '$1'" >&2; exit 2; }
       target=$1; shift ;;
  esac
done
case "$target" in
  aarch64|arm64) deb_arch=arm64 qemu_arch=aarch64 ;;
  armhf) die "armhf images are not built yet: Debian's armhf kernels boot through U-Boot or board firmware, not a generic EFI image (docs/robot-image.md says what it would take)" 2 ;;
  "") echo "$prog: name the target: aarch64 (try --help)" >&2; exit 2 ;;
  *) die "unknown target '$target' (aarch64)" 2 ;;
esac
[[ -n "$out" ]] || die "--out FILE is required (try --help)" 2
[[ "$size" =~ ^([0-9]+)([MG])$ ]] || die "--size '$size': expected a number of M or G, e.g. 2G or 1536M" 2
size_mib=$((10#${BASH_REMATCH[1]}))
[[ ${BASH_REMATCH[2]} == G ]] && size_mib=$((size_mib * 1024))
((size_mib >= 1024)) || die "--size $size: at least 1G (the root file system alone needs about 700 MiB)" 2
if [[ -n "$hostname" ]]; then
  [[ "$hostname" =~ ^[a-zA-Z0-9]([a-zA-Z0-9-]{0,61}[a-zA-Z0-9])?$ ]] ||
    die "--hostname '$hostname': letters, digits and inner hyphens, at most 63" 2
fi

# ---- inputs, checked before anything is built
if [[ -z "$package" ]]; then
  package=$(find "$here/build/aarch64/packages" -maxdepth 1 -name "cairn-robot_*_$deb_arch.deb" -printf '%T@ %p\n' 2>/dev/null |
            sort -rn | head -n 1 | cut -d' ' -f2- || true)
  [[ -n "$package" ]] || die "no cairn-robot $deb_arch package in build/aarch64/packages: run scripts/package.sh aarch64, or give --package"
fi
[[ -f "$package" ]] || die "package '$package' not found"
pkg_name=$(dpkg-deb -f "$package" Package 2>/dev/null) || die "'$package' is not a Debian package"
[[ "$pkg_name" == cairn-robot ]] || die "'$package' is package '$pkg_name', expected cairn-robot"
pkg_arch=$(dpkg-deb -f "$package" Architecture)
[[ "$pkg_arch" == "$deb_arch" ]] || die "'$package' is for $pkg_arch, the image is $deb_arch"
package=$(realpath "$package")
if [[ -n "$config" ]]; then
  [[ -f "$config" ]] || die "configuration '$config' not found"
  config=$(realpath "$config")
fi
if [[ -n "$dds_profile" ]]; then
  [[ -f "$dds_profile" ]] || die "DDS profile '$dds_profile' not found"
  grep -q '<CycloneDDS' "$dds_profile" || die "'$dds_profile' is not a Cyclone DDS configuration (no <CycloneDDS> element)"
  [[ -n "$config" ]] || die "--dds-profile needs a --config that uses it: [dds] profile = \"/etc/cairn/dds.xml\" (the package's example uses the loopback profile)"
  grep -Eq '^[[:space:]]*profile[[:space:]]*=[[:space:]]*"/etc/cairn/dds.xml"' "$config" ||
    die "'$config' must use the image's profile: [dds] profile = \"/etc/cairn/dds.xml\""
  dds_profile=$(realpath "$dds_profile")
fi
# shellcheck source=SCRIPTDIR/lib/robot-keys.sh disable=SC1091
source "$here/scripts/lib/robot-keys.sh"
if [[ -n "$keys" ]]; then
  [[ -n "$config" ]] || die "--keys needs a --config that uses them: [dds] profile = \"secure\", keys = \"/etc/cairn/keys\""
  command -v openssl >/dev/null || die "--keys: openssl is needed to check the keys (apt-get install openssl)"
  why=$(check_robot_keys "$keys" "$config") || die "keys refused: $why"
  keys=$(realpath "$keys")
fi
for k in "${ssh_keys[@]}"; do
  [[ -f "$k" ]] || die "SSH key '$k' not found"
  grep -Eq '^(ssh-|ecdsa-|sk-)[a-z0-9@.-]+ [A-Za-z0-9+/=]+' "$k" || die "'$k' is not an OpenSSH public key (give the .pub file)"
done
if [[ -z "$hostname" ]]; then
  cfg_for_name=${config:-}
  if [[ -z "$cfg_for_name" ]]; then
    cfg_for_name=$(mktemp); dpkg-deb --fsys-tarfile "$package" | tar -xO ./etc/cairn/robot.toml >"$cfg_for_name" 2>/dev/null || true
  fi
  hostname=$(sed -nE 's/^[[:space:]]*name[[:space:]]*=[[:space:]]*"([a-zA-Z0-9-]{1,63})".*/\1/p' "$cfg_for_name" | head -n 1)
  [[ -n "${config:-}" ]] || rm -f "$cfg_for_name"
  [[ -n "$hostname" ]] || hostname=cairn-robot
fi
((${#ssh_keys[@]})) || echo "$prog: WARNING: no --ssh-key: password logins are off and root has no password, so nobody can log in to this image" >&2
out_dir=$(dirname "$out")
[[ -d "$out_dir" && -w "$out_dir" ]] || die "cannot write '$out': no such directory, or not writable"
# The image is written next to --out and moved over it: never onto a device (flash.sh does that).
[[ ! -e "$out" || -f "$out" ]] || die "'$out' exists and is not a regular file: --out names the image file (write it to a card with scripts/flash.sh)"
# The scratch directory's root/ is deleted: only a new or empty directory, or one this script made.
[[ -n "$work" ]] || work=/tmp/cairn-image/work.$$
if [[ -e "$work" ]]; then
  [[ -d "$work" ]] || die "--work-dir '$work' is not a directory"
  [[ -z "$(ls -A "$work")" || -e "$work/.cairn-make-image" ]] ||
    die "--work-dir '$work' is not empty and was not made by make-image.sh: give a new or empty directory"
fi
[[ $(id -u) -eq 0 ]] || die "needs root: mmdebstrap's root mode and the root file system's ownership (run with sudo)"

# ---- host tools
stage "host tools"
# shellcheck source=SCRIPTDIR/lib/apt.sh disable=SC1091
source "$here/scripts/lib/apt.sh"
apt_install_missing "$prog" mmdebstrap qemu-user-static binfmt-support fdisk e2fsprogs dosfstools mtools uuid-runtime \
  >/dev/null || die "could not install the host tools (mmdebstrap qemu-user-static binfmt-support fdisk e2fsprogs dosfstools mtools uuid-runtime)"
mke2fs -V 2>&1 | grep -Eq 'mke2fs 1\.(4[3-9]|[5-9][0-9])' || die "mkfs.ext4 -d needs e2fsprogs >= 1.43"

# ---- binfmt_misc: running the arm64 maintainer scripts (chroot) goes through qemu-aarch64
stage "binfmt_misc for qemu-$qemu_arch"
bm=/proc/sys/fs/binfmt_misc
if [[ ! -e $bm/register ]]; then
  mount -t binfmt_misc binfmt_misc "$bm" 2>/dev/null ||
    die "binfmt_misc is not mounted and mounting it failed (in a container: mount it on the host, or run with --privileged); foreign-architecture chroots need it"
fi
if [[ ! -e $bm/qemu-$qemu_arch ]]; then
  update-binfmts --enable "qemu-$qemu_arch" 2>/dev/null || true
fi
if [[ ! -e $bm/qemu-$qemu_arch ]]; then
  # Register it ourselves: the F flag opens the interpreter now, so it works inside the chroot.
  interp=/usr/libexec/qemu-binfmt/$qemu_arch-binfmt-P
  [[ -x $interp ]] || interp=/usr/bin/qemu-$qemu_arch-static
  [[ -x $interp ]] || die "no qemu-$qemu_arch interpreter (install qemu-user-static)"
  printf '%s\n' ":qemu-$qemu_arch:M::\\x7fELF\\x02\\x01\\x01\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x02\\x00\\xb7\\x00:\\xff\\xff\\xff\\xff\\xff\\xff\\xff\\x00\\xff\\xff\\xff\\xff\\xff\\xff\\xff\\xff\\xfe\\xff\\xff\\xff:$interp:FP" \
    >"$bm/register" 2>/dev/null || die "could not register qemu-$qemu_arch with binfmt_misc ($bm/register)"
fi
grep -qx enabled "$bm/qemu-$qemu_arch" || die "binfmt_misc entry qemu-$qemu_arch is disabled: echo 1 > $bm/qemu-$qemu_arch"
grep -q '^flags:.*F' "$bm/qemu-$qemu_arch" ||
  die "binfmt_misc entry qemu-$qemu_arch lacks the F flag (its interpreter would have to exist inside the chroot): update-binfmts --disable qemu-$qemu_arch; then rerun"

# ---- scratch space
mkdir -p "$work"
work=$(realpath "$work")
touch "$work/.cairn-make-image"
root=$work/root
cleanup() {
  # mmdebstrap unmounts what it mounted in the root even when it fails; if anything is still
  # mounted there, leave the directory alone rather than delete through a mount.
  if grep -q " $root/" /proc/mounts 2>/dev/null; then
    echo "$prog: something is still mounted under $root (see /proc/mounts): not removing it" >&2
  else
    rm -rf --one-file-system "$root"
  fi
  rm -f "$work"/esp.img "$work"/root.img "$work"/hook.sh "$work"/BOOTAA64.EFI "$out.partial"
  rm -f "$work/.cairn-make-image"
  rmdir "$work" 2>/dev/null || true
}
trap cleanup EXIT
rm -rf --one-file-system "$root"

# ---- the root file system
# minbase (Priority: required + apt), then only what a robot computer needs to boot and be
# reached: the kernel and an initramfs, systemd as init, udev, networkd (in systemd), SSH.
# GRUB's arm64-efi image is made inside the chroot, then GRUB is removed again.
packages=(
  linux-image-arm64 initramfs-tools systemd systemd-sysv systemd-timesyncd udev dbus kmod
  openssh-server iproute2 netbase
  grub-efi-arm64-bin
)
cat >"$work/hook.sh" <<'HOOK'
#!/bin/sh
# Runs inside mmdebstrap's customize stage: $1 is the root, /dev /proc /sys are mounted.
set -eu
r=$1 deb=$2 config=$3 dds=$4 keys=$5
# The initramfs: made once, here, not at every trigger during the installation (each run
# takes minutes under qemu-user); update-initramfs was diverted by the essential hook.
rm -f "$r/usr/sbin/update-initramfs"
chroot "$r" dpkg-divert --quiet --local --rename --remove /usr/sbin/update-initramfs
for v in $(ls "$r/lib/modules"); do
  chroot "$r" update-initramfs -c -k "$v"
  chroot "$r" linux-update-symlinks install "$v" "/boot/vmlinuz-$v"
done
cp "$deb" "$r/tmp/cairn-robot.deb"
chroot "$r" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends /tmp/cairn-robot.deb
rm -f "$r/tmp/cairn-robot.deb"
if [ -n "$config" ]; then install -m 0644 "$config" "$r/etc/cairn/robot.toml"; fi
if [ -n "$dds" ]; then install -m 0644 "$dds" "$r/etc/cairn/dds.xml"; fi
# The keys, for the service user only (the package's postinst made it): robot-keys.sh's function.
if [ -n "$keys" ]; then . "$(dirname "$0")/install-robot-keys.sh" && install_robot_keys "$keys" "$r"; fi
# The image's own cairn-robot (arm64, under qemu-user) validates the configuration it ships.
chroot "$r" /usr/bin/cairn-robot --config /etc/cairn/robot.toml --check-config
# GRUB as one EFI binary with the modules it needs built in: it finds the root file system by
# its label and reads /boot/grub/grub.cfg there, which boots the /vmlinuz and /initrd.img
# links the kernel package keeps current (a kernel update needs no GRUB step).
cat >"$r/tmp/grub-early.cfg" <<'EOF'
search --no-floppy --label --set=root cairn-root
set prefix=($root)/boot/grub
configfile $prefix/grub.cfg
EOF
chroot "$r" grub-mkimage -O arm64-efi -o /tmp/BOOTAA64.EFI -p /boot/grub -c /tmp/grub-early.cfg \
  part_gpt fat ext2 search search_label search_fs_uuid normal configfile linux echo test gzio sleep efi_gop
chroot "$r" env DEBIAN_FRONTEND=noninteractive apt-get purge -y -q --auto-remove grub-efi-arm64-bin grub-common
chroot "$r" apt-get clean
HOOK
chmod +x "$work/hook.sh"
declare -f install_robot_keys >"$work/install-robot-keys.sh"

stage "mmdebstrap bookworm $deb_arch (minbase + kernel, systemd, ssh, cairn-robot)"
inc=$(IFS=,; echo "${packages[*]}")
# Before the kernel and initramfs-tools go in: update-initramfs diverted to true (see hook.sh).
# shellcheck disable=SC2016  # $1 is mmdebstrap's, expanded by its hook shell
divert_hook='chroot "$1" dpkg-divert --quiet --local --rename --add /usr/sbin/update-initramfs && ln -s /bin/true "$1/usr/sbin/update-initramfs"'
cache_hooks=()
if [[ -n "$apt_cache" ]]; then
  mkdir -p "$apt_cache"
  apt_cache=$(realpath "$apt_cache")
  cache_hooks=(--setup-hook="mkdir -p \"\$1/var/cache/apt/archives\"; cp -a \"$apt_cache\"/. \"\$1/var/cache/apt/archives/\""
               --customize-hook="cp -a \"\$1/var/cache/apt/archives\"/*.deb \"$apt_cache\"/ 2>/dev/null || true")
fi
mmdebstrap --mode=root --variant=minbase --architectures="$deb_arch" --include="$inc" \
  --dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/locale/*' \
  --dpkgopt='path-include=/usr/share/locale/locale.alias' \
  --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-include=/usr/share/doc/*/copyright' \
  --dpkgopt='path-include=/usr/share/doc/cairn-robot/*' \
  "${cache_hooks[@]}" \
  --essential-hook="$divert_hook" \
  --customize-hook="\"$work/hook.sh\" \"\$1\" \"$package\" \"${config:-}\" \"${dds_profile:-}\" \"${keys:-}\"" \
  --customize-hook="mv \"\$1/tmp/BOOTAA64.EFI\" \"$work/BOOTAA64.EFI\"" \
  bookworm "$root" \
  "deb $mirror bookworm main" "deb $mirror bookworm-updates main" \
  "deb ${mirror%/debian}/debian-security bookworm-security main" ||
  die "mmdebstrap failed (above: which package or hook); the mirror was $mirror"
[[ -s "$work/BOOTAA64.EFI" ]] || die "GRUB's EFI image was not made"
[[ -e "$root/vmlinuz" && -e "$root/initrd.img" ]] || die "the kernel package left no /vmlinuz and /initrd.img links"

# ---- the system's own settings (on the directory, no chroot needed)
stage "configuration: hostname $hostname, fstab, network, ssh, units"
esp_uuid=$(uuidgen) root_uuid=$(uuidgen) root_fs_uuid=$(uuidgen)
esp_serial=$(od -An -N4 -tx1 /dev/urandom | tr -d ' \n' | tr a-f A-F)
echo "$hostname" >"$root/etc/hostname"
printf '127.0.0.1\tlocalhost\n127.0.1.1\t%s\n::1\t\tlocalhost ip6-localhost ip6-loopback\n' "$hostname" >"$root/etc/hosts"
cat >"$root/etc/fstab" <<EOF
# <file system>                              <mount>    <type> <options>                      <dump> <pass>
PARTUUID=$root_uuid  /          ext4   defaults,noatime,x-systemd.growfs 0 1
PARTUUID=$esp_uuid  /boot/efi  vfat   umask=0077,nofail              0 2
EOF
mkdir -p "$root/boot/efi" "$root/boot/grub"
cat >"$root/boot/grub/grub.cfg" <<EOF
# Cairn robot image (scripts/make-image.sh). Boots the /vmlinuz and /initrd.img links, which
# the kernel package keeps pointing at the newest kernel. CPU isolation for the RT loop
# (docs/robot-image.md) is not set: to isolate CPU 1, the [rt] cpu of robot.toml, add
#   isolcpus=1 nohz_full=1 rcu_nocbs=1
# to the linux line below.
set timeout=1
set default=0
menuentry "Debian bookworm (Cairn robot)" {
  linux /vmlinuz root=PARTUUID=$root_uuid rootfstype=ext4 rw console=tty1 console=ttyAMA0,115200 quiet
  initrd /initrd.img
}
EOF
# The root partition grows to fill the card at first boot (systemd-repart), then the file
# system (x-systemd.growfs in fstab).
mkdir -p "$root/etc/repart.d"
printf '[Partition]\nType=root-arm64\n' >"$root/etc/repart.d/50-root.conf"
# Wired network: DHCP on every Ethernet port (a fleet's static address: docs/robot-image.md).
mkdir -p "$root/etc/systemd/network"
printf '[Match]\nName=en* eth*\n\n[Network]\nDHCP=yes\n' >"$root/etc/systemd/network/20-wired.network"
# cairn-robot.service waits for network-online.target: a robot booted without its cable (or
# without a DHCP answer) starts it after 20 s, not after wait-online's default 2 min.
mkdir -p "$root/etc/systemd/system/systemd-networkd-wait-online.service.d"
printf '[Service]\nExecStart=\nExecStart=/lib/systemd/systemd-networkd-wait-online --any --timeout=20\n' \
  >"$root/etc/systemd/system/systemd-networkd-wait-online.service.d/50-cairn.conf"
# SSH: keys only. Host keys are made at first boot, so robots flashed from one image differ.
install -d -m 0755 "$root/etc/ssh/sshd_config.d"
printf 'PasswordAuthentication no\nKbdInteractiveAuthentication no\nPermitRootLogin prohibit-password\n' \
  >"$root/etc/ssh/sshd_config.d/50-cairn.conf"
rm -f "$root"/etc/ssh/ssh_host_*
cat >"$root/etc/systemd/system/cairn-ssh-hostkeys.service" <<'EOF'
[Unit]
Description=Generate this robot's SSH host keys (first boot)
Before=ssh.service
ConditionPathExists=!/etc/ssh/ssh_host_ed25519_key

[Service]
Type=oneshot
ExecStart=/usr/bin/ssh-keygen -A

[Install]
WantedBy=ssh.service
EOF
install -d -m 0700 "$root/root/.ssh"
: >"$root/root/.ssh/authorized_keys"
for k in "${ssh_keys[@]}"; do cat "$k" >>"$root/root/.ssh/authorized_keys"; done
chmod 0600 "$root/root/.ssh/authorized_keys"
# Root: no password (locked), so only the keys above open it.
sed -i -E 's/^root:[^:]*:/root:*:/' "$root/etc/shadow"
# A machine id of its own on each robot: empty means "generate at first boot".
: >"$root/etc/machine-id"
rm -f "$root/var/lib/dbus/machine-id"
systemctl --root="$root" enable cairn-robot.service systemd-networkd.service ssh.service cairn-ssh-hostkeys.service >/dev/null 2>&1 ||
  die "systemctl --root enable failed"
# Journal on the card: persistent, but bounded.
mkdir -p "$root/etc/systemd/journald.conf.d" "$root/var/log/journal"
printf '[Journal]\nStorage=persistent\nSystemMaxUse=64M\n' >"$root/etc/systemd/journald.conf.d/50-cairn.conf"
# What went in, for the record (and the docs' figures).
echo "built $(date -u +%FT%TZ) by scripts/make-image.sh from $(basename "$package") $(dpkg-deb -f "$package" Version)" \
  >"$root/etc/cairn/image-info"

# ---- file systems and the disk
esp_mib=256
root_mib=$((size_mib - esp_mib - 2))  # 1 MiB before the ESP, 1 MiB for the backup GPT
used_mib=$(( $(du -sm "$root" | cut -f1) ))
((used_mib + 100 < root_mib)) || die "the root file system needs ${used_mib} MiB + room; --size $size leaves ${root_mib} MiB: give a larger --size"
stage "ext4 root file system (${used_mib} MiB of files in ${root_mib} MiB)"
mkfs.ext4 -q -L cairn-root -U "$root_fs_uuid" -d "$root" "$work/root.img" "${root_mib}M" ||
  die "mkfs.ext4 -d failed"
stage "EFI system partition (FAT32, ${esp_mib} MiB)"
rm -f "$work/esp.img"
mkfs.vfat -F 32 -n EFI -i "$esp_serial" -C "$work/esp.img" $((esp_mib * 1024)) >/dev/null || die "mkfs.vfat failed"
mmd -i "$work/esp.img" ::/EFI ::/EFI/BOOT
mcopy -i "$work/esp.img" "$work/BOOTAA64.EFI" ::/EFI/BOOT/BOOTAA64.EFI || die "mcopy to the ESP failed"
stage "disk image: GPT, ESP + root"
rm -f "$out.partial"
truncate -s "${size_mib}M" "$out.partial"
[[ -z "$keys" ]] || chmod 600 "$out.partial"  # it holds the robot's private key
sfdisk --quiet "$out.partial" <<EOF || die "sfdisk failed"
label: gpt
unit: sectors
start=2048, size=$((esp_mib * 2048)), type=C12A7328-F81F-11D2-BA4B-00A0C93EC93B, uuid=$esp_uuid, name="EFI"
start=$(((1 + esp_mib) * 2048)), size=$((root_mib * 2048)), type=B921B045-1DF0-41C3-AF44-4C6F280D3FAE, uuid=$root_uuid, name="cairn-root"
EOF
dd if="$work/esp.img" of="$out.partial" bs=1M seek=1 conv=notrunc,sparse status=none || die "writing the ESP failed"
dd if="$work/root.img" of="$out.partial" bs=1M seek=$((1 + esp_mib)) conv=notrunc,sparse status=none || die "writing the root failed"
mv "$out.partial" "$out"
stage "done: $out ($size_mib MiB, $(du -h "$out" | cut -f1) allocated; root PARTUUID $root_uuid; hostname $hostname)"
