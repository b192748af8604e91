#!/usr/bin/env bash
# Installs the Debian packages Cairn needs, by name, skipping those already
# installed. Idempotent; safe to run again. Needs root (uses sudo if not root).
#
#   scripts/setup-deps.sh            build + test dependencies (the web view's browser
#                                    test included: chromium, chromium-driver, python3-selenium)
#   scripts/setup-deps.sh --peers    also the peer baselines used by benchmarks (MRPT)
#   scripts/setup-deps.sh --vm       also what the qemu VM bench needs
#   scripts/setup-deps.sh --cross    also the aarch64/armhf cross toolchains and target libraries
set -euo pipefail

core=(
  ca-certificates cmake ninja-build g++ clang libclang-rt-14-dev pkg-config file bc
  libeigen3-dev
  cyclonedds-dev cyclonedds-tools
  libmodbus-dev libserialport-dev
  libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libpng-dev zlib1g-dev libboost-dev gnuplot-nox
  googletest libgtest-dev libgmock-dev libbenchmark-dev
  libsystemd-dev dpkg-dev openssh-client openssh-server
  mount fdisk e2fsprogs xz-utils openssl
  chromium chromium-driver python3-selenium   # web_view_browser_test (tests/web/web_view_test.py)
  iproute2 util-linux
)
extra=()
vm_kernel=0
for arg in "$@"; do
  case "$arg" in
    --peers) extra+=(libmrpt-dev) ;;
    --vm) extra+=(qemu-system-x86 busybox-static cpio); vm_kernel=1 ;;
    --cross) extra+=(g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user qemu-user-static) ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "setup-deps: unknown option '$arg' (try --help)" >&2; exit 2 ;;
  esac
done

source "$(dirname "$0")/lib/apt.sh"
apt_install_missing setup-deps "${core[@]}" "${extra[@]}"
if ((vm_kernel)); then
  source "$(dirname "$0")/lib/vm-kernel.sh"
  fetch_vm_kernel "$(cd "$(dirname "$0")/.." && pwd)/build/vm-kernel"
fi
