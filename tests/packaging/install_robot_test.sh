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

# 4. With the robot's DDS Security keys (scripts/fleet-keys.sh): installed as /etc/cairn/keys,
# readable by the service user only; keys that are not this robot's, or revoked, never leave.
fleet="$work/fleet"
"$src/scripts/fleet-keys.sh" init "$fleet" >/dev/null || fail "fleet-keys.sh init failed"
"$src/scripts/fleet-keys.sh" add "$fleet" robot 7 >/dev/null && "$src/scripts/fleet-keys.sh" add "$fleet" robot 8 >/dev/null ||
  fail "fleet-keys.sh add failed"
sed -e 's/^id = .*/id = 7/' -e 's/^name = .*/name = "robot-7"/' \
    -e 's|^profile = .*|profile = "secure-loopback"\nkeys = "/etc/cairn/keys"|' "$src/config/robot.toml" >"$work/robot-7s.toml"
keys_cmd=("$src/scripts/install-robot.sh" --target "$user@127.0.0.1" --port "$port" --identity "$work/client_key"
          --ssh-option StrictHostKeyChecking=no --ssh-option UserKnownHostsFile=/dev/null
          --package "$deb" --config "$work/robot-7s.toml" --root "$root" --restart-command "echo restarted >> $root/restarts")
out=$("${keys_cmd[@]}" --keys "$fleet/members/robot-7" --dry-run) || fail "dry run with keys failed: $out"
grep -q "tar -C $fleet/members/robot-7 -cf - cert.pem key.pem" <<<"$out" || fail "the dry run did not show the keys' copy: $out"
# A staging root without the service user: installed, root's, with a warning.
out=$("${keys_cmd[@]}" --keys "$fleet/members/robot-7" 2>&1) || fail "install with keys failed: $out"
grep -q "no user cairn in $root/etc/passwd" <<<"$out" || fail "no warning about the missing service user: $out"
[[ $(stat -c %u "$root/etc/cairn/keys/key.pem") == 0 ]] || fail "keys not root's without a service user"
# With the service user (as the package's postinst makes it on a robot): the keys are its own.
echo "cairn:x:4242:4242::/nonexistent:/usr/sbin/nologin" >>"$root/etc/passwd"
"${keys_cmd[@]}" --keys "$fleet/members/robot-7" >/dev/null 2>&1 || fail "second install with keys failed"
[[ $(stat -c %a:%u:%g "$root/etc/cairn/keys") == 500:4242:4242 ]] ||
  fail "/etc/cairn/keys is $(stat -c %a:%u:%g "$root/etc/cairn/keys"), want 500:4242:4242 (the service user's only)"
for f in cert.pem key.pem ca.pem governance.p7s permissions.p7s crl.pem; do
  [[ $(stat -c %a:%u:%g "$root/etc/cairn/keys/$f") == 400:4242:4242 ]] ||
    fail "/etc/cairn/keys/$f is $(stat -c %a:%u:%g "$root/etc/cairn/keys/$f"), want 400:4242:4242"
  cmp -s "$fleet/members/robot-7/$f" "$root/etc/cairn/keys/$f" || fail "/etc/cairn/keys/$f is not robot 7's"
done
ls -d "$root"/etc/cairn/keys.* >/dev/null 2>&1 && fail "an old or half-made keys directory was left behind"
if [[ "$(dpkg-deb -f "$deb" Architecture)" == "$(dpkg --print-architecture)" ]]; then
  sed "s|\"/etc/cairn/keys\"|\"$root/etc/cairn/keys\"|" "$root/etc/cairn/robot.toml" >"$work/installed-s.toml"
  # The secure profile refuses a keys directory it cannot read whole: this passes only with the keys.
  check=$("$root/usr/bin/cairn-robot" --config "$work/installed-s.toml" --check-config 2>&1) || fail "installed secure config invalid: $check"
fi
msg=$("${keys_cmd[@]}" --keys "$fleet/members/robot-8" 2>&1) && fail "robot 8's keys were installed on robot 7"
grep -q "keys refused: the keys in .* are robot-8's, the configuration is robot 7's" <<<"$msg" || fail "unclear error for another robot's keys: $msg"
cp -r "$fleet/members/robot-7" "$work/old-7"
"$src/scripts/fleet-keys.sh" renew "$fleet" robot-7 >/dev/null || fail "fleet-keys.sh renew failed"
cp "$fleet/crl.pem" "$work/old-7/crl.pem"  # the superseded keys, with the fleet's current revocation list
msg=$("${keys_cmd[@]}" --keys "$work/old-7" 2>&1) && fail "robot 7's superseded keys were installed"
grep -q "keys refused: robot-7's certificate does not verify .*certificate revoked" <<<"$msg" || fail "unclear error for revoked keys: $msg"
cmp -s "$fleet/members/robot-7/cert.pem" "$root/etc/cairn/keys/cert.pem" && fail "the renewed certificate was installed before it was sent"
"${keys_cmd[@]}" --keys "$fleet/members/robot-7" >/dev/null 2>&1 || fail "install of the renewed keys failed"
cmp -s "$fleet/members/robot-7/cert.pem" "$root/etc/cairn/keys/cert.pem" || fail "the renewed certificate did not replace the old one"
echo "keys: installed 0400 for the service user only; another robot's and superseded keys refused; renewed keys replace the old"

# 5. Clear refusals, before anything is sent.
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
