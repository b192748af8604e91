#!/usr/bin/env bash
# Smoke test of scripts/make-image.sh and scripts/image-test.sh that CI can afford (~2 s):
# their usage errors (exit status 2) and the refusals make-image.sh makes before it builds
# anything (exit status 1, one clear line). Builds no image and boots nothing: the full
# build and boot take many minutes (docs/robot-image.md). ctest: image_scripts_smoke.
#   tests/image/image_scripts_smoke.sh [SOURCE_DIR]
set -uo pipefail
src=${1:-$(cd "$(dirname "$0")/../.." && pwd)}
mk=$src/scripts/make-image.sh it=$src/scripts/image-test.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 n=0

# expect STATUS PATTERN CMD...: CMD exits with STATUS and says something matching PATTERN
expect() {
  local want=$1 pattern=$2 out rc
  shift 2
  n=$((n + 1))
  out=$("$@" 2>&1 </dev/null); rc=$?
  if [[ $rc -ne $want ]] || ! grep -Eq -- "$pattern" <<<"$out"; then
    echo "FAIL: $* -> status $rc (want $want), output: $(head -c 300 <<<"$out")"
    fails=$((fails + 1))
  fi
}

for s in "$mk" "$it"; do
  n=$((n + 1))
  bash -n "$s" || { echo "FAIL: bash -n $s"; fails=$((fails + 1)); }
  if command -v shellcheck >/dev/null; then
    n=$((n + 1))
    shellcheck "$s" >/dev/null || { echo "FAIL: shellcheck $s"; shellcheck "$s" | head -20; fails=$((fails + 1)); }
  fi
done

# A fake cairn-robot package of the right name and architecture, and a wrong one.
fake_deb() {  # NAME ARCH OUT
  local d=$tmp/deb-$1-$2
  mkdir -p "$d/DEBIAN" "$d/etc/cairn"
  printf 'Package: %s\nVersion: 0.0.1\nArchitecture: %s\nMaintainer: test <t@example.org>\nDescription: test\n' "$1" "$2" >"$d/DEBIAN/control"
  printf '[robot]\nid = 3\nname = "robot-3"\n' >"$d/etc/cairn/robot.toml"
  dpkg-deb --build --root-owner-group "$d" "$3" >/dev/null
}
fake_deb cairn-robot arm64 "$tmp/robot-arm64.deb"
fake_deb cairn-robot amd64 "$tmp/robot-amd64.deb"
fake_deb cairn-base arm64 "$tmp/base-arm64.deb"
printf '[robot]\nid = 3\n[dds]\nprofile = "loopback"\n' >"$tmp/loopback.toml"
printf '[robot]\nid = 3\n[dds]\nprofile = "/etc/cairn/dds.xml"\n' >"$tmp/fleet.toml"
printf '<CycloneDDS><Domain/></CycloneDDS>\n' >"$tmp/fleet.xml"
printf '<notdds/>\n' >"$tmp/bad.xml"
ssh-keygen -q -t ed25519 -N '' -f "$tmp/key" >/dev/null 2>&1 || printf 'ssh-ed25519 AAAAC3NzaC1lZDI1NTE5AAAAIB test\n' >"$tmp/key.pub"
ok=(--package "$tmp/robot-arm64.deb" --out "$tmp/robot.img")

# make-image.sh: usage errors (2)
expect 0 'make-image.sh aarch64' "$mk" --help
expect 2 'name the target' "$mk" --out "$tmp/x.img"
expect 2 'unknown target' "$mk" sparc --out "$tmp/x.img"
expect 2 'armhf images are not built' "$mk" armhf --out "$tmp/x.img"
expect 2 'one target only' "$mk" aarch64 aarch64 --out "$tmp/x.img"
expect 2 'unknown option' "$mk" aarch64 --bogus
expect 2 '--out FILE is required' "$mk" aarch64
expect 2 '--size needs a value' "$mk" aarch64 --out "$tmp/x.img" --size
expect 2 "--size '2T'" "$mk" aarch64 --out "$tmp/x.img" --size 2T
expect 2 'at least 1G' "$mk" aarch64 --out "$tmp/x.img" --size 512M
expect 2 "--hostname 'bad_name'" "$mk" aarch64 "${ok[@]}" --hostname bad_name
# make-image.sh: refusals before building (1)
expect 1 "package '.*/missing.deb' not found" "$mk" aarch64 --package "$tmp/missing.deb" --out "$tmp/x.img"
expect 1 'not a Debian package' "$mk" aarch64 --package "$tmp/fleet.xml" --out "$tmp/x.img"
expect 1 "is package 'cairn-base', expected cairn-robot" "$mk" aarch64 --package "$tmp/base-arm64.deb" --out "$tmp/x.img"
expect 1 'is for amd64, the image is arm64' "$mk" aarch64 --package "$tmp/robot-amd64.deb" --out "$tmp/x.img"
expect 1 "configuration '.*/missing.toml' not found" "$mk" aarch64 "${ok[@]}" --config "$tmp/missing.toml"
expect 1 "DDS profile '.*/missing.xml' not found" "$mk" aarch64 "${ok[@]}" --config "$tmp/fleet.toml" --dds-profile "$tmp/missing.xml"
expect 1 'not a Cyclone DDS configuration' "$mk" aarch64 "${ok[@]}" --config "$tmp/fleet.toml" --dds-profile "$tmp/bad.xml"
expect 1 '--dds-profile needs a --config' "$mk" aarch64 "${ok[@]}" --dds-profile "$tmp/fleet.xml"
expect 1 'must use the image.s profile' "$mk" aarch64 "${ok[@]}" --config "$tmp/loopback.toml" --dds-profile "$tmp/fleet.xml"
# --keys: a robot's own DDS Security keys only (scripts/lib/robot-keys.sh checks them; the
# install itself is install_robot_test's, the same function).
"$src/scripts/fleet-keys.sh" init "$tmp/fleet" >/dev/null && "$src/scripts/fleet-keys.sh" add "$tmp/fleet" robot 3 >/dev/null &&
  "$src/scripts/fleet-keys.sh" add "$tmp/fleet" robot 4 >/dev/null || { echo "FAIL: fleet-keys.sh"; fails=$((fails + 1)); }
printf '[robot]\nid = 3\n[dds]\nprofile = "secure"\ninterface = "eth0"\npeers = ["10.0.0.1"]\nkeys = "/etc/cairn/keys"\n' >"$tmp/secure.toml"
expect 1 '--keys needs a --config' "$mk" aarch64 "${ok[@]}" --keys "$tmp/fleet/members/robot-3"
expect 1 "keys refused: keys directory '.*/nokeys' not found" "$mk" aarch64 "${ok[@]}" --config "$tmp/secure.toml" --keys "$tmp/nokeys"
expect 1 'keys refused: .*must be "secure"' "$mk" aarch64 "${ok[@]}" --config "$tmp/loopback.toml" --keys "$tmp/fleet/members/robot-3"
expect 1 "keys refused: the keys in .* are robot-4's, the configuration is robot 3's" "$mk" aarch64 "${ok[@]}" --config "$tmp/secure.toml" --keys "$tmp/fleet/members/robot-4"
# A member directory put together from two robots' files, and documents the CA did not sign.
cp -r "$tmp/fleet/members/robot-3" "$tmp/mixed" && cp "$tmp/fleet/members/robot-4/permissions.p7s" "$tmp/mixed/"
expect 1 "keys refused: the permissions in .* are robot-4's, the certificate is robot-3's" "$mk" aarch64 "${ok[@]}" --config "$tmp/secure.toml" --keys "$tmp/mixed"
cp -r "$tmp/fleet/members/robot-3" "$tmp/tampered" && sed -i 's/robot-3/robot-9/' "$tmp/tampered/permissions.p7s"
expect 1 "keys refused: '.*/permissions.p7s' is not signed by the fleet CA" "$mk" aarch64 "${ok[@]}" --config "$tmp/secure.toml" --keys "$tmp/tampered"
cp -r "$tmp/fleet/members/robot-3" "$tmp/foreign" && "$src/scripts/fleet-keys.sh" init "$tmp/fleet2" >/dev/null &&
  cp "$tmp/fleet2/governance.p7s" "$tmp/foreign/" || { echo "FAIL: a second fleet"; fails=$((fails + 1)); }
expect 1 "keys refused: '.*/governance.p7s' is not signed by the fleet CA" "$mk" aarch64 "${ok[@]}" --config "$tmp/secure.toml" --keys "$tmp/foreign"
expect 1 "SSH key '.*/nokey.pub' not found" "$mk" aarch64 "${ok[@]}" --ssh-key "$tmp/nokey.pub"
expect 1 'not an OpenSSH public key' "$mk" aarch64 "${ok[@]}" --ssh-key "$tmp/key"
expect 1 'cannot write' "$mk" aarch64 --package "$tmp/robot-arm64.deb" --ssh-key "$tmp/key.pub" --out "$tmp/nodir/robot.img"
mkfifo "$tmp/fifo.img"  # --out must be the image file, never a device or anything else
expect 1 'exists and is not a regular file' "$mk" aarch64 "${ok[@]}" --out "$tmp/fifo.img"
mkdir -p "$tmp/busy" && touch "$tmp/busy/keep"  # its root/ would be deleted: only new, empty or its own
expect 1 "--work-dir '.*/busy' is not empty" "$mk" aarch64 "${ok[@]}" --work-dir "$tmp/busy"
[[ -e "$tmp/busy/keep" ]] || { echo "FAIL: a refused --work-dir lost a file"; fails=$((fails + 1)); }

# image-test.sh: usage errors (2) and images it refuses (1)
expect 0 'image-test.sh robot.img' "$it" --help
expect 2 'name the image' "$it"
expect 2 'unknown option' "$it" --bogus x.img
expect 2 "--timeout 'soon'" "$it" x.img --timeout soon
expect 2 "--grow '1T'" "$it" x.img --grow 1T
expect 1 "image '.*/missing.img' not found" "$it" "$tmp/missing.img"
if command -v sfdisk >/dev/null; then  # checked before the root check and before any install
  truncate -s 8M "$tmp/blank.img"
  expect 1 'no partition table' "$it" "$tmp/blank.img"
  printf 'label: gpt\nsize=4M, type=0FC63DAF-8483-4772-8E79-3D69D8477DE4\n' | sfdisk -q "$tmp/blank.img" >/dev/null
  expect 1 'has no root partition' "$it" "$tmp/blank.img"
fi

if ((fails)); then echo "image_scripts_smoke: $fails of $n checks FAILED"; exit 1; fi
echo "image_scripts_smoke: all $n checks passed"
