#!/usr/bin/env bash
# Builds the Debian packages for one architecture into build/<preset>/packages:
#   scripts/package.sh host       cairn-robot, cairn-base, cairn-hil for this machine (release build)
#   scripts/package.sh aarch64    cairn-robot for 64-bit Arm robot computers
#   scripts/package.sh armhf      cairn-robot for 32-bit Arm robot computers
# Install one onto a robot with scripts/install-robot.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  host) preset=release; scripts/setup-deps.sh ;;
  aarch64|armhf) preset=$1; scripts/setup-cross.sh "$1" ;;
  -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
  *) echo "package: name an architecture: host, aarch64 or armhf" >&2; exit 2 ;;
esac
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
out=build/$preset/packages
rm -rf "$out"
(cd "build/$preset" && cpack -G DEB -B "$PWD/packages" >/dev/null)
rm -rf "$out/_CPack_Packages"
for deb in "$out"/*.deb; do
  echo "package: $deb ($(dpkg-deb -f "$deb" Architecture), $(du -h "$deb" | cut -f1))"
done
