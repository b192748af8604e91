#!/usr/bin/env bash
# scripts/install-robot.sh against a target on this machine: an sshd of the test's own on
# 127.0.0.1 (its own host key, client key and port), installing into a throw-away root.
#   install_robot_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$1 build=$(cd "$2" && pwd)
export CAIRN_ROBOT_BIN="$build/firmware/cairn-robot"  # validates configurations before sending
work=$(mktemp -d)
sshd_pid=""
cleanup() { [[ -n "$sshd_pid" ]] && kill "$sshd_pid" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; [[ -f "$work/sshd.log" ]] && sed 's/^/sshd: /' "$work/sshd.log" >&2; exit 1; }

sshd=$(command -v sshd || echo /usr/sbin/sshd)
[[ -x "$sshd" ]] || fail "no sshd (openssh-server; scripts/setup-deps.sh installs it)"
mkdir -p /run/sshd 2>/dev/null || true  # privilege separation directory (as root)

# The robot package of this build.
(cd "$build" && cpack -G DEB -B "$work/out" >/dev/null) || fail "cpack failed"
deb=$(echo "$work"/out/cairn-robot_*.deb)
[[ -f "$deb" ]] || fail "no cairn-robot package"

# The target: sshd on loopback with keys of its own.
ssh-keygen -q -t ed25519 -N '' -f "$work/host_key"
ssh-keygen -q -t ed25519 -N '' -f "$work/client_key"
cp "$work/client_key.pub" "$work/authorized_keys"
chmod 600 "$work/authorized_keys"
user=$(id -un)
port=""
for try in $(seq 1 20); do
  candidate=$((20000 + (RANDOM % 20000)))
  cat >"$work/sshd_config" <<CFG
ListenAddress 127.0.0.1
Port $candidate
HostKey $work/host_key
AuthorizedKeysFile $work/authorized_keys
PasswordAuthentication no
KbdInteractiveAuthentication no
PermitRootLogin prohibit-password
StrictModes no
UsePAM no
PidFile $work/sshd.pid
LogLevel ERROR
CFG
  "$sshd" -D -e -f "$work/sshd_config" 2>"$work/sshd.log" &
  sshd_pid=$!
  for _ in $(seq 1 50); do
    if ssh -p "$candidate" -i "$work/client_key" -o BatchMode=yes -o StrictHostKeyChecking=no -o UserKnownHostsFile=/dev/null \
         -o LogLevel=ERROR "$user@127.0.0.1" true 2>/dev/null; then port=$candidate; break; fi
    kill -0 "$sshd_pid" 2>/dev/null || break
    sleep 0.1
  done
  [[ -n "$port" ]] && break
  kill "$sshd_pid" 2>/dev/null || true; wait "$sshd_pid" 2>/dev/null || true; sshd_pid=""
done
[[ -n "$port" ]] || fail "could not start a test sshd on 127.0.0.1"
echo "target: $user@127.0.0.1:$port (test sshd $sshd_pid)"

# This robot's own configuration and DDS profile.
root="$work/target-root"
sed -e 's/^id = .*/id = 7/' -e 's/^name = .*/name = "robot-7"/' \
    -e 's|^profile = .*|profile = "/etc/cairn/dds.xml"|' "$src/config/robot.toml" >"$work/robot-7.toml"
grep -q '^id = 7' "$work/robot-7.toml" || fail "could not make robot 7's configuration"
cp "$src/config/dds/loopback.xml" "$work/dds.xml"
install_cmd=("$src/scripts/install-robot.sh" --target "$user@127.0.0.1" --port "$port" --identity "$work/client_key"
             --ssh-option StrictHostKeyChecking=no --ssh-option UserKnownHostsFile=/dev/null
             --package "$deb" --config "$work/robot-7.toml" --dds-profile "$work/dds.xml" --root "$root"
             --restart-command "echo restarted >> $root/restarts")

# 1. --dry-run prints the steps and changes nothing.
out=$("${install_cmd[@]}" --dry-run) || fail "dry run failed: $out"
echo "$out"
grep -q "dry run" <<<"$out" || fail "dry run did not say so"
grep -q "dpkg --root=$root" <<<"$out" || fail "dry run did not show the dpkg step"
grep -q "cat > /tmp/cairn-install" <<<"$out" || fail "dry run did not show the copy step"
[[ ! -e "$root" ]] || fail "dry run touched the target root"

# 2. The install: package, configuration, profile, restart.
"${install_cmd[@]}" || fail "install-robot.sh failed"
[[ -x "$root/usr/bin/cairn-robot" ]] || fail "cairn-robot not installed in the target root"
cmp -s "$work/robot-7.toml" "$root/etc/cairn/robot.toml" || fail "/etc/cairn/robot.toml is not robot 7's configuration"
cmp -s "$work/dds.xml" "$root/etc/cairn/dds.xml" || fail "/etc/cairn/dds.xml is not the given profile"
[[ -f "$root/lib/systemd/system/cairn-robot.service" ]] || fail "no systemd unit in the target root"
dpkg --root="$root" -l 2>/dev/null | grep -q '^ii  cairn-robot' || fail "dpkg in the target root does not list cairn-robot as installed"
[[ $(grep -c restarted "$root/restarts" 2>/dev/null) == 1 ]] || fail "the restart command did not run once"
ls /tmp/cairn-install.* >/dev/null 2>&1 && fail "the staging directory was left behind" || true
if [[ "$(dpkg-deb -f "$deb" Architecture)" == "$(dpkg --print-architecture)" ]]; then
  # In the throw-away root the profile sits under $root, not at /etc/cairn/dds.xml.
  sed "s|\"/etc/cairn/dds.xml\"|\"$root/etc/cairn/dds.xml\"|" "$root/etc/cairn/robot.toml" >"$work/installed.toml"
  check=$("$root/usr/bin/cairn-robot" --config "$work/installed.toml" --check-config 2>&1) || fail "installed config invalid: $check"
  grep -q "robot 7 (robot-7)" <<<"$check" || fail "the installed robot is not robot 7: $check"
  echo "installed: $(tail -n 1 <<<"$check")"
fi

# 3. Again, with a changed configuration: the robot's file wins over the package's conffile.
sed -i 's/^name = .*/name = "robot-7b"/' "$work/robot-7.toml"
"${install_cmd[@]}" >/dev/null || fail "second install failed"
grep -q 'name = "robot-7b"' "$root/etc/cairn/robot.toml" || fail "the second install did not update the configuration"
[[ $(grep -c restarted "$root/restarts") == 2 ]] || fail "the second install did not restart"

# 4. Clear refusals, before anything is sent.
msg=$("$src/scripts/install-robot.sh" --target "$user@127.0.0.1" --port "$port" --package "$work/none.deb" \
        --config "$work/robot-7.toml" 2>&1) && fail "a missing package was accepted"
grep -q "not found" <<<"$msg" || fail "unclear error for a missing package: $msg"
sed 's/^id = .*/id = "seven"/' "$work/robot-7.toml" >"$work/bad.toml"
msg=$("${install_cmd[@]/$work\/robot-7.toml/$work/bad.toml}" 2>&1) && fail "a bad configuration was accepted"
grep -q "configuration rejected" <<<"$msg" || fail "unclear error for a bad configuration: $msg"
echo "bad configuration refused: $(tail -n 1 <<<"$msg")"
kill "$sshd_pid"; wait "$sshd_pid" 2>/dev/null || true; sshd_pid=""
msg=$("${install_cmd[@]}" 2>&1) && fail "an unreachable target was accepted"
grep -q "cannot reach" <<<"$msg" || fail "unclear error for an unreachable target: $msg"
echo "unreachable target: $(tail -n 1 <<<"$msg")"
echo "PASS"
