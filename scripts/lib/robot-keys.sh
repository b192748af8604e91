# shellcheck shell=bash
# A robot's DDS Security keys (a member directory of scripts/fleet-keys.sh, docs/security.md):
# checked on this machine before they go anywhere, then installed as /etc/cairn/keys
# readable by the service user only. Sourced by install-robot.sh and make-image.sh.

robot_key_files="cert.pem key.pem ca.pem governance.p7s permissions.p7s crl.pem"

# check_robot_keys DIR CONFIG: 0 when DIR holds robot ID's keys for CONFIG ([robot] id = ID),
# its certificate verifies against its CA and revocation list, the key is the certificate's,
# the governance and permissions are signed by that CA and the permissions are this robot's,
# and CONFIG names them ([dds] profile secure or secure-loopback, keys = "/etc/cairn/keys").
# Otherwise prints the reason on stdout and returns 1. A certificate or revocation list that
# ends within 30 days is a warning on stderr.
check_robot_keys() {
  local dir=$1 config=$2 f missing="" id cn err end grant
  [[ -d $dir ]] || { echo "keys directory '$dir' not found"; return 1; }
  for f in $robot_key_files; do [[ -r $dir/$f ]] || missing+=" $f"; done
  [[ -z $missing ]] || { echo "keys directory '$dir' lacks$missing (scripts/fleet-keys.sh add FLEET robot ID makes one)"; return 1; }
  grep -Eq '^[[:space:]]*profile[[:space:]]*=[[:space:]]*"(secure|secure-loopback)"' "$config" ||
    { echo "'$config' does not use the keys: with --keys its [dds] profile must be \"secure\" (or \"secure-loopback\")"; return 1; }
  grep -Eq '^[[:space:]]*keys[[:space:]]*=[[:space:]]*"/etc/cairn/keys/?"' "$config" ||
    { echo "'$config' must name the installed keys: [dds] keys = \"/etc/cairn/keys\""; return 1; }
  id=$(awk '/^[[:space:]]*\[/ { s = $0; gsub(/[[:space:]]/, "", s) }
            s == "[robot]" && /^[[:space:]]*id[[:space:]]*=/ { sub(/#.*/, ""); gsub(/[^0-9]/, ""); print; exit }' "$config")
  cn=$(openssl x509 -in "$dir/cert.pem" -noout -subject -nameopt multiline 2>/dev/null | sed -n 's/^ *commonName *= *//p')
  [[ -n $cn ]] || { echo "'$dir/cert.pem' is not a certificate"; return 1; }
  [[ $cn == "robot-$id" ]] || { echo "the keys in '$dir' are $cn's, the configuration is robot ${id:-?}'s"; return 1; }
  err=$(openssl verify -CAfile "$dir/ca.pem" -crl_check -CRLfile "$dir/crl.pem" "$dir/cert.pem" 2>&1) ||
    { echo "$cn's certificate does not verify against its fleet CA and revocation list: $(grep -m1 -i 'error' <<<"$err" || echo "$err")"; return 1; }
  [[ $(openssl pkey -in "$dir/key.pem" -pubout 2>/dev/null) == "$(openssl x509 -in "$dir/cert.pem" -noout -pubkey 2>/dev/null)" ]] ||
    { echo "'$dir/key.pem' is not the key of $cn's certificate"; return 1; }
  # The signed documents: Cyclone refuses to start on governance or permissions its CA did
  # not sign, or on permissions granted to somebody else (a member directory put together
  # from two robots' files): say so here, not in the robot's journal after the flash.
  for f in governance.p7s permissions.p7s; do
    openssl smime -verify -in "$dir/$f" -CAfile "$dir/ca.pem" -out /dev/null >/dev/null 2>&1 ||
      { echo "'$dir/$f' is not signed by the fleet CA in '$dir/ca.pem'"; return 1; }
  done
  grant=$(openssl smime -verify -in "$dir/permissions.p7s" -CAfile "$dir/ca.pem" 2>/dev/null |
          sed -n 's/.*<grant name="\([^"]*\)".*/\1/p' | head -n1)
  [[ $grant == "$cn" ]] || { echo "the permissions in '$dir' are ${grant:-nobody}'s, the certificate is $cn's"; return 1; }
  if ! openssl x509 -in "$dir/cert.pem" -noout -checkend $((30 * 86400)) >/dev/null; then
    end=$(openssl x509 -in "$dir/cert.pem" -noout -enddate | cut -d= -f2)
    echo "WARNING: $cn's certificate ends on $end: renew it (scripts/fleet-keys.sh renew FLEET $cn)" >&2
  fi
  end=$(openssl crl -in "$dir/crl.pem" -noout -nextupdate | cut -d= -f2)
  if (($(date -d "$end" +%s) < $(date +%s) + 30 * 86400)); then
    echo "WARNING: the revocation list in '$dir' expires on $end: sign it again (scripts/fleet-keys.sh crl FLEET) and copy it out" >&2
  fi
  return 0
}

# install_robot_keys SRC ROOT: SRC's key files into ROOT/etc/cairn/keys (ROOT "" for /),
# owned by the service user `cairn` (from ROOT/etc/passwd), the directory 0500 and the files
# 0400: nobody else reads them. Replaces an older set whole (for a moment between the two
# renames there is none: the service, if running, keeps its files open). POSIX sh, run
# under `set -e` (a failed step stops it before the old set is touched): install-robot.sh
# runs it on the robot (declare -f), make-image.sh on the image's root.
install_robot_keys() {
  ik_src=$1
  ik_root=$2
  ik_owner=$(awk -F: '$1 == "cairn" { print $3 ":" $4 }' "$ik_root/etc/passwd" 2>/dev/null || true)  # no passwd: no user
  if [ -z "$ik_owner" ]; then
    if [ -z "$ik_root" ]; then echo "keys: no user cairn on this system (the cairn-robot package makes it)" >&2; return 1; fi
    echo "keys: WARNING: no user cairn in $ik_root/etc/passwd (a staging root): the keys stay root's" >&2
    ik_owner=0:0
  fi
  mkdir -p "$ik_root/etc/cairn"
  rm -rf "$ik_root/etc/cairn/keys.new" "$ik_root/etc/cairn/keys.old"
  mkdir -m 0700 "$ik_root/etc/cairn/keys.new"
  for ik_f in cert.pem key.pem ca.pem governance.p7s permissions.p7s crl.pem; do
    install -m 0400 "$ik_src/$ik_f" "$ik_root/etc/cairn/keys.new/$ik_f"
  done
  chown -R "$ik_owner" "$ik_root/etc/cairn/keys.new"
  chmod 0500 "$ik_root/etc/cairn/keys.new"
  if [ -e "$ik_root/etc/cairn/keys" ]; then mv "$ik_root/etc/cairn/keys" "$ik_root/etc/cairn/keys.old"; fi
  mv "$ik_root/etc/cairn/keys.new" "$ik_root/etc/cairn/keys"
  rm -rf "$ik_root/etc/cairn/keys.old"
}
