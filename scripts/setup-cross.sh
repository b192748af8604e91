#!/usr/bin/env bash
# Installs what cross-building the robot side needs, by Debian package name: the cross
# compiler for each target, qemu-user to run the target's tests, and the target's
# libraries. Idempotent; needs root (uses sudo if not root). Host tools (cmake, idlc) come
# from scripts/setup-deps.sh.
#   aarch64: the arm64 libraries through Debian multiarch (dpkg --add-architecture arm64).
#   armhf:   a sysroot in build/sysroot/armhf (mmdebstrap, bookworm + bookworm-updates).
#            Multiarch needs every armhf library at exactly the host's version, so one
#            security update the mirror has not yet indexed for armhf blocks it; a sysroot
#            has its own consistent set and leaves the host's dpkg alone.
#
#   scripts/setup-cross.sh aarch64     64-bit Arm (Raspberry Pi 4/5, Jetson-class)
#   scripts/setup-cross.sh armhf       32-bit Arm (older boards)
#   scripts/setup-cross.sh all
set -euo pipefail
cd "$(dirname "$0")/.."

targets=()
for arg in "$@"; do
  case "$arg" in
    aarch64|arm64) targets+=(arm64) ;;
    armhf|arm) targets+=(armhf) ;;
    all) targets+=(arm64 armhf) ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "setup-cross: unknown target '$arg' (aarch64, armhf, all)" >&2; exit 2 ;;
  esac
done
((${#targets[@]})) || { echo "setup-cross: name a target: aarch64, armhf or all" >&2; exit 2; }

scripts/setup-deps.sh
source "$(dirname "$0")/lib/apt.sh"

wanted=(qemu-user)
sysroot_targets=()
# The robot side's libraries for the target (Eigen, CLI11, json are header-only and
# architecture-independent; idlc runs on the host).
target_libs=(cyclonedds-dev libmodbus-dev libserialport-dev libtomlplusplus-dev libsystemd-dev libgtest-dev libgmock-dev zlib1g-dev)
for arch in "${targets[@]}"; do
  if [[ $arch == armhf ]]; then
    wanted+=(g++-arm-linux-gnueabihf mmdebstrap)
    sysroot_targets+=(armhf)
    continue
  fi
  if ! dpkg --print-foreign-architectures | grep -qx "$arch"; then
    need_root setup-cross
    echo "setup-cross: dpkg --add-architecture $arch"
    "${SUDO[@]}" dpkg --add-architecture "$arch"
  fi
  wanted+=(g++-aarch64-linux-gnu)
  # libc6/libstdc++6 of the target: the loader and runtime qemu-user runs the tests with.
  wanted+=("libc6:$arch" "libstdc++6:$arch")
  for lib in "${target_libs[@]}"; do wanted+=("$lib:$arch"); done
done

apt_install_missing setup-cross "${wanted[@]}"

# build/sysroot/<arch>: the target's libc, libstdc++ and libraries unpacked (not installed:
# nothing of the target runs at setup). Rebuilt when the package list changes.
for arch in "${sysroot_targets[@]}"; do
  root=build/sysroot/$arch
  want="${target_libs[*]} libc6-dev libstdc++-12-dev libeigen3-dev libcli11-dev nlohmann-json3-dev cyclonedds-tools"
  if [[ -f $root/.cairn-packages && $(cat "$root/.cairn-packages") == "$want" ]]; then
    echo "setup-cross: sysroot $root is up to date"
    continue
  fi
  need_root setup-cross
  mirror=${CAIRN_DEBIAN_MIRROR:-http://deb.debian.org/debian}
  echo "setup-cross: unpacking the $arch sysroot into $root from $mirror (bookworm, bookworm-updates)..."
  "${SUDO[@]}" rm -rf "$root.tmp"
  mkdir -p build/sysroot
  "${SUDO[@]}" mmdebstrap --quiet --variant=extract --skip=cleanup/apt/cache --architectures="$arch" --include="${want// /,}" \
    bookworm "$root.tmp" "deb $mirror bookworm main" "deb $mirror bookworm-updates main"
  # The packages' symbols and shlibs files in DEBIAN/ at the sysroot's top: dpkg-shlibdeps
  # (the Depends of scripts/package.sh) reads them for libraries found under that directory.
  "${SUDO[@]}" bash -c 'mkdir -p "$1/DEBIAN"
    for deb in "$1"/var/cache/apt/archives/*.deb; do
      for f in symbols shlibs; do
        dpkg-deb --ctrl-tarfile "$deb" | tar -xO "./$f" 2>/dev/null >> "$1/DEBIAN/$f" || true
      done
    done
    rm -rf "$1"/var/cache/apt/archives' _ "$root.tmp"
  # Not a chroot: without its own /dev, qemu-user -L falls through to the host's devices
  # (the emulated programs' /dev/ptmx would otherwise be the sysroot's dead node).
  "${SUDO[@]}" rm -rf "$root.tmp/dev"
  printf '%s' "$want" | "${SUDO[@]}" tee "$root.tmp/.cairn-packages" >/dev/null
  "${SUDO[@]}" rm -rf "$root"
  "${SUDO[@]}" mv "$root.tmp" "$root"
  echo "setup-cross: sysroot $root ready ($(du -sh "$root" | cut -f1))"
done
