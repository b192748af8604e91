#!/usr/bin/env bash
# Installs what cross-building the robot side needs, by Debian package name: the cross
# compiler for each target, qemu-user to run the target's tests, and the target's
# libraries through Debian multiarch (dpkg --add-architecture). Idempotent; needs root
# (uses sudo if not root). Host tools (cmake, idlc) come from scripts/setup-deps.sh.
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
for arch in "${targets[@]}"; do
  if ! dpkg --print-foreign-architectures | grep -qx "$arch"; then
    need_root setup-cross
    echo "setup-cross: dpkg --add-architecture $arch"
    "${SUDO[@]}" dpkg --add-architecture "$arch"
  fi
  case "$arch" in
    arm64) wanted+=(g++-aarch64-linux-gnu) ;;
    armhf) wanted+=(g++-arm-linux-gnueabihf) ;;
  esac
  # The robot side's libraries for the target (Eigen, CLI11, json are header-only and
  # architecture-independent; idlc runs on the host).
  # libc6/libstdc++6 of the target: the loader and runtime qemu-user runs the tests with.
  wanted+=("libc6:$arch" "libstdc++6:$arch")
  wanted+=("cyclonedds-dev:$arch" "libmodbus-dev:$arch" "libserialport-dev:$arch" "libtomlplusplus-dev:$arch" "libsystemd-dev:$arch"
           "libgtest-dev:$arch" "libgmock-dev:$arch" "zlib1g-dev:$arch")
done

apt_install_missing setup-cross "${wanted[@]}"
