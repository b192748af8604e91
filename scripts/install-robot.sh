#!/usr/bin/env bash
# Installs a cairn-robot package and one robot's own configuration onto a robot computer
# over SSH, then restarts the service.
#
#   scripts/install-robot.sh --target [USER@]HOST --package cairn-robot_0.1.0_arm64.deb \
#       --config robot-7.toml [--dds-profile fleet.xml] [options]
#
#   --target [USER@]HOST   the robot computer (ssh; key-based login, the user must be root
#                          or have passwordless sudo)
#   --port N               ssh port (default 22)
#   --identity FILE        ssh private key
#   --ssh-option OPT       extra ssh -o option, repeatable (e.g. StrictHostKeyChecking=no)
#   --package FILE.deb     the cairn-robot package for the robot's architecture
#                          (scripts/package.sh aarch64|armhf|host)
#   --config FILE.toml     this robot's configuration (robot id, device URIs, [dds]); becomes
#                          /etc/cairn/robot.toml
#   --dds-profile FILE.xml this robot's Cyclone DDS profile; becomes /etc/cairn/dds.xml, and
#                          the configuration must say  [dds] profile = "/etc/cairn/dds.xml"
#   --keys DIR             this robot's DDS Security keys (scripts/fleet-keys.sh add FLEET robot ID
#                          made DIR = FLEET/members/robot-ID); become /etc/cairn/keys, readable
#                          by the service user only; the configuration must say
#                          [dds] profile = "secure" (or "secure-loopback"), keys = "/etc/cairn/keys".
#                          Refused unless they are this robot's, verify against their CA and
#                          revocation list, and the key is the certificate's
#   --root DIR             install into DIR on the target instead of / (a staging or test
#                          root: dependencies are not installed, nothing is restarted unless
#                          --restart-command says so)
#   --restart-command CMD  run on the target instead of  systemctl restart cairn-robot.service
#   --dry-run              check the inputs and print every step; touch nothing, connect nowhere
set -euo pipefail

die() { echo "install-robot: $*" >&2; exit 1; }
usage() { sed -n '2,29p' "$0"; }
shq() { local q="'\\''"; printf "'%s'" "${1//\'/$q}"; }  # single-quoted for the target's sh

target="" port=22 identity="" package="" config="" dds_profile="" keys="" root="/" restart_cmd="" dry_run=0
ssh_opts=(-o BatchMode=yes -o ConnectTimeout=10 -o LogLevel=ERROR)
while (($#)); do
  case "$1" in
    --target) target=${2:?--target needs a value}; shift 2 ;;
    --port) port=${2:?--port needs a value}; shift 2 ;;
    --identity) identity=${2:?--identity needs a value}; shift 2 ;;
    --ssh-option) ssh_opts+=(-o "${2:?--ssh-option needs a value}"); shift 2 ;;
    --package) package=${2:?--package needs a value}; shift 2 ;;
    --config) config=${2:?--config needs a value}; shift 2 ;;
    --dds-profile) dds_profile=${2:?--dds-profile needs a value}; shift 2 ;;
    --keys) keys=${2:?--keys needs a value}; shift 2 ;;
    --root) root=${2:?--root needs a value}; shift 2 ;;
    --restart-command) restart_cmd=${2:?--restart-command needs a value}; shift 2 ;;
    --dry-run) dry_run=1; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "install-robot: unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[[ -n "$target" ]] || die "--target [USER@]HOST is required"
[[ -n "$package" ]] || die "--package FILE.deb is required"
[[ -n "$config" ]] || die "--config FILE.toml is required"
[[ "$port" =~ ^[0-9]+$ ]] || die "--port: expected a number, got '$port'"
[[ "$root" == /* ]] || die "--root: expected an absolute path on the target, got '$root'"

# ---- local checks: refuse before touching the robot
[[ -f "$package" ]] || die "package '$package' not found"
pkg_name=$(dpkg-deb -f "$package" Package 2>/dev/null) || die "'$package' is not a Debian package"
[[ "$pkg_name" == cairn-robot ]] || die "'$package' is package '$pkg_name', expected cairn-robot"
pkg_arch=$(dpkg-deb -f "$package" Architecture)
pkg_version=$(dpkg-deb -f "$package" Version)
[[ -f "$config" ]] || die "configuration '$config' not found"
if [[ -n "$dds_profile" ]]; then
  [[ -f "$dds_profile" ]] || die "DDS profile '$dds_profile' not found"
  grep -q '<CycloneDDS' "$dds_profile" || die "'$dds_profile' is not a Cyclone DDS configuration (no <CycloneDDS> element)"
  grep -Eq '^[[:space:]]*profile[[:space:]]*=[[:space:]]*"/etc/cairn/dds.xml"' "$config" ||
    die "'$config' must use the installed profile: [dds] profile = \"/etc/cairn/dds.xml\""
fi
here=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=SCRIPTDIR/lib/robot-keys.sh disable=SC1091
source "$here/scripts/lib/robot-keys.sh"
if [[ -n "$keys" ]]; then
  command -v openssl >/dev/null || die "--keys: openssl is needed to check the keys (apt-get install openssl)"
  why=$(check_robot_keys "$keys" "$config") || die "keys refused: $why"
fi
# Validate the configuration with a cairn-robot of this machine, when there is one
# ($CAIRN_ROBOT_BIN, then PATH, then this checkout's build).
checker=""
for c in "${CAIRN_ROBOT_BIN:-}" "$(command -v cairn-robot || true)" "$here"/build/release/firmware/cairn-robot \
         "$here"/build/ci/firmware/cairn-robot; do
  if [[ -n "$c" && -x "$c" ]]; then checker=$c; break; fi
done
if [[ -n "$checker" ]]; then
  checked=$config
  if [[ -n "$dds_profile" || -n "$keys" ]]; then  # not at /etc/cairn yet: check against the files given
    checked=$(mktemp --suffix=.toml)
    trap 'rm -f "$checked"' EXIT
    cp "$config" "$checked"
    [[ -z "$dds_profile" ]] || sed -i "s|\"/etc/cairn/dds.xml\"|\"$(realpath "$dds_profile")\"|" "$checked"
    [[ -z "$keys" ]] || sed -Ei "s|\"/etc/cairn/keys/?\"|\"$(realpath "$keys")\"|" "$checked"
  fi
  summary=$("$checker" --config "$checked" --check-config 2>&1) || die "configuration rejected: ${summary//$checked/$config}"
  echo "install-robot: $(echo "$summary" | tail -n 1)"
else
  echo "install-robot: no local cairn-robot to validate '$config' with; the robot checks it before restarting"
fi

ssh_cmd=(ssh -p "$port" "${ssh_opts[@]}")
[[ -n "$identity" ]] && ssh_cmd+=(-i "$identity")
stage="/tmp/cairn-install.$$"
r=${root%/}  # "" for /
if [[ -z "$r" ]]; then
  # A live robot: apt resolves the package's dependencies; the robot validates its config.
  install_step="apt-get install -y -q --no-install-recommends -o Dpkg::Options::=--force-confold $stage/pkg.deb"
  check_step="cairn-robot --config /etc/cairn/robot.toml --check-config"
  [[ -n "$restart_cmd" ]] || restart_cmd="systemctl restart cairn-robot.service"
else
  # A staging root: dpkg with that root; maintainer scripts run outside it (DPKG_ROOT set,
  # they then leave users and services alone) and dependencies are not installed there.
  install_step="mkdir -p $r/var/lib/dpkg/info $r/var/lib/dpkg/updates && touch $r/var/lib/dpkg/status"
  install_step+=" && { dpkg --root=$r --print-foreign-architectures | grep -qx $pkg_arch || [ \"\$(dpkg --print-architecture)\" = $pkg_arch ] || dpkg --root=$r --add-architecture $pkg_arch; }"
  install_step+=" && dpkg --root=$r --force-script-chrootless --force-depends --force-confold --log=$r/var/log/dpkg.log -i $stage/pkg.deb"
  check_step=""
fi
sudo_prefix='if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi'
remote_script="set -e
$sudo_prefix
mkdir -p $r/var/log
\$SUDO sh -c $(shq "$install_step")
\$SUDO install -D -m 0644 $stage/robot.toml $r/etc/cairn/robot.toml"
[[ -n "$dds_profile" ]] && remote_script+="
\$SUDO install -D -m 0644 $stage/dds.xml $r/etc/cairn/dds.xml"
[[ -n "$keys" ]] && remote_script+="
\$SUDO sh -c $(shq "set -e
$(declare -f install_robot_keys)
install_robot_keys $stage/keys '$r'")"
[[ -n "$check_step" ]] && remote_script+="
$check_step"
[[ -n "$restart_cmd" ]] && remote_script+="
\$SUDO sh -c $(shq "$restart_cmd")"
remote_script+="
rm -rf $stage"

echo "install-robot: $pkg_name $pkg_version ($pkg_arch) + $(basename "$config") -> $target:$root"
steps=("${ssh_cmd[*]} $target 'mkdir -m 0700 $stage'"
       "${ssh_cmd[*]} $target 'cat > $stage/pkg.deb' < $package"
       "${ssh_cmd[*]} $target 'cat > $stage/robot.toml' < $config")
[[ -n "$dds_profile" ]] && steps+=("${ssh_cmd[*]} $target 'cat > $stage/dds.xml' < $dds_profile")
[[ -n "$keys" ]] && steps+=("tar -C $keys -cf - $robot_key_files | ${ssh_cmd[*]} $target 'mkdir -m 0700 $stage/keys && tar -C $stage/keys -xf -'")
steps+=("${ssh_cmd[*]} $target sh -s <<'EOF'"$'\n'"$remote_script"$'\n'"EOF")
[[ -n "$restart_cmd" ]] || echo "install-robot: staging root: the service is not restarted (give --restart-command to run one)"
if ((dry_run)); then
  echo "install-robot: dry run; these steps would run:"
  for s in "${steps[@]}"; do echo "  \$ $s"; done
  exit 0
fi

remote() { "${ssh_cmd[@]}" "$target" "$@"; }
echo "install-robot: [1/3] connecting, staging in $stage"
remote "mkdir -m 0700 $stage" || die "cannot reach $target on port $port over ssh (see the ssh error above)"
echo "install-robot: [2/3] copying the package and the configuration${keys:+ and the keys}"
remote "cat > $stage/pkg.deb" < "$package"
remote "cat > $stage/robot.toml" < "$config"
[[ -n "$dds_profile" ]] && remote "cat > $stage/dds.xml" < "$dds_profile"
if [[ -n "$keys" ]]; then
  # shellcheck disable=SC2086  # the file names: one word each
  tar -C "$keys" -cf - $robot_key_files | remote "mkdir -m 0700 $stage/keys && tar -C $stage/keys -xf -" ||
    die "copying the keys to $target failed"
fi
echo "install-robot: [3/3] installing${restart_cmd:+ and restarting}"
if ! remote sh -s <<<"$remote_script"; then
  remote "rm -rf $stage" || true
  die "installation on $target failed (see above)"
fi
echo "install-robot: done: $pkg_name $pkg_version on $target:$root"
