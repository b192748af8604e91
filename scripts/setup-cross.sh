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
SUDO=()
if [[ $(id -u) -ne 0 ]]; then SUDO=(sudo); fi

wanted=(qemu-user)
for arch in "${targets[@]}"; do
  if ! dpkg --print-foreign-architectures | grep -qx "$arch"; then
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

missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "setup-cross: all ${#wanted[@]} packages already installed"
  exit 0
fi
echo "setup-cross: installing ${#missing[@]} package(s): ${missing[*]}"
# A mirror mid-sync fails an index now and then ("File has unexpected size"): retry.
for try in 1 2 3; do
  # always: a new architecture's package lists are not there yet
  "${SUDO[@]}" apt-get update -q && break
  # Still failing: install from the lists that did download; a missing package fails below.
  ((try < 3)) || { echo "setup: apt-get update failed 3 times; installing from the lists it has" >&2; break; }
  echo "setup: apt-get update failed; retrying in 15 s" >&2; sleep 15
done
DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "setup-cross: done"
