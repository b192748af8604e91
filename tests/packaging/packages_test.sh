#!/usr/bin/env bash
# The packages of one build: they build, hold what they should, install into a scratch
# root with dpkg, and the installed cairn-robot runs (under qemu-user for a foreign arch).
#   packages_test.sh BUILD_DIR [EMULATOR ARGS...]
set -euo pipefail
build=$1; shift
emulator=("$@")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

(cd "$build" && cpack -G DEB -B "$work/out" >/dev/null) || fail "cpack failed in $build"
arch=$(sed -n 's/^set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "\(.*\)")/\1/p' "$build/CPackConfig.cmake")
[[ -n "$arch" ]] || fail "no package architecture in $build/CPackConfig.cmake"
shopt -s nullglob
debs=("$work"/out/*.deb)
echo "built ${#debs[@]} package(s) for $arch: $(cd "$work/out" && ls ./*.deb | tr '\n' ' ')"

# expect PACKAGE PATH...: every path is in the package
expect() {
  local pkg=$1; shift
  local deb="$work/out/${pkg}_"*"_${arch}.deb"
  deb=$(echo $deb)
  [[ -f "$deb" ]] || fail "no $pkg package for $arch"
  local listing
  listing=$(dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|')
  for p in "$@"; do grep -qx "$p" <<<"$listing" || fail "$pkg lacks $p"; done
  [[ $(dpkg-deb -f "$deb" Architecture) == "$arch" ]] || fail "$pkg: architecture $(dpkg-deb -f "$deb" Architecture), expected $arch"
  echo "$pkg: $(grep -c . <<<"$listing") entries; Depends: $(dpkg-deb -f "$deb" Depends)"
}
expect cairn-robot /usr/bin/cairn-robot /usr/bin/cairn-lms-probe /etc/cairn/robot.toml \
  /lib/systemd/system/cairn-robot.service /usr/share/cairn/udev/99-cairn-lms.rules /usr/share/cairn/dds/lan.xml \
  /usr/lib/sysctl.d/60-cairn-robot.conf \
  /usr/share/doc/cairn-robot/firmware.md
robot_deb=$(echo "$work"/out/cairn-robot_*_"$arch".deb)
dpkg-deb -f "$robot_deb" Depends | grep -q libddsc0debian || fail "cairn-robot does not depend on Cyclone DDS"
dpkg-deb -I "$robot_deb" conffiles | grep -qx /etc/cairn/robot.toml || fail "/etc/cairn/robot.toml is not a conffile"
unit=$(dpkg-deb --fsys-tarfile "$robot_deb" | tar -xO ./lib/systemd/system/cairn-robot.service)
for key in LimitRTPRIO= LimitMEMLOCK= Restart=on-failure WatchdogSec= Type=notify; do
  grep -q "^$key" <<<"$unit" || fail "cairn-robot.service lacks $key"
done
# The units parse: systemd-analyze reports unknown keys and bad values (a missing
# /usr/bin/cairn-* on this machine, or targets a container lacks, are not the unit's fault).
if command -v systemd-analyze >/dev/null; then
  mkdir -p "$work/units"
  for deb in "${debs[@]}"; do
    dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$work/units" --wildcards './lib/systemd/system/*' 2>/dev/null || true
  done
  for u in "$work"/units/lib/systemd/system/*.service; do
    problems=$(systemd-analyze verify "$u" 2>&1 | grep -v -e 'is not executable' -e 'not found' -e 'Failed to create' || true)
    [[ -z "$problems" ]] || fail "$(basename "$u"): $problems"
    echo "$(basename "$u"): systemd-analyze verify clean"
  done
fi
if grep -q CAIRN_HOST_ONLY_PARTS:BOOL=ON "$build/CMakeCache.txt"; then
  expect cairn-base /usr/bin/cairn-base /usr/bin/cairn-eval /usr/bin/cairn-map-quality /usr/share/doc/cairn-base/mapper.md \
    /etc/cairn/base.toml /lib/systemd/system/cairn-base.service /usr/lib/sysctl.d/60-cairn-base.conf
  base_deb=$(echo "$work"/out/cairn-base_*_"$arch".deb)
  dpkg-deb -f "$base_deb" Depends | grep -q libpng16 || fail "cairn-base does not depend on libpng (the map PNG export)"
  expect cairn-hil /usr/bin/cairn-hil /usr/share/cairn/worlds/office.world /usr/share/cairn/hil/robot-hil.toml
fi

# Install into a scratch root (no dependencies there; maintainer scripts see DPKG_ROOT).
root="$work/root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates"
touch "$root/var/lib/dpkg/status"
[[ "$(dpkg --print-architecture)" == "$arch" ]] || dpkg --root="$root" --add-architecture "$arch"
for deb in "${debs[@]}"; do
  dpkg --root="$root" --force-script-chrootless --force-depends --log=/dev/null -i "$deb" >"$work/dpkg.log" 2>&1 ||
    { cat "$work/dpkg.log"; fail "dpkg could not install $(basename "$deb") into a scratch root"; }
done
status=$(dpkg --root="$root" -s "cairn-robot:$arch" 2>/dev/null | grep '^Status:' || true)
[[ "$status" == "Status: install ok installed" ]] || fail "cairn-robot not installed in the scratch root ($status)"
[[ -x "$root/usr/bin/cairn-robot" ]] || fail "no executable $root/usr/bin/cairn-robot"

help=$("${emulator[@]}" "$root/usr/bin/cairn-robot" --help 2>&1) || fail "installed cairn-robot --help failed: $help"
grep -q "cairn-robot: the Cairn robot executive" <<<"$help" || fail "unexpected --help output: $help"
check=$("${emulator[@]}" "$root/usr/bin/cairn-robot" --config "$root/etc/cairn/robot.toml" --check-config 2>&1) ||
  fail "the installed default configuration does not validate: $check"
echo "installed cairn-robot ($arch${emulator:+, under ${emulator[0]}}) runs; default configuration: $(tail -n 1 <<<"$check")"
echo "PASS"
