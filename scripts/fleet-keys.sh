#!/usr/bin/env bash
# The fleet's DDS Security keys (issue 20; docs/security.md): one CA, a certificate and key
# per member, the signed governance and each member's signed permissions, in one directory.
#
#   scripts/fleet-keys.sh init DIR [--domain N] [--days N] [--ca-days N]
#                                                            a new fleet: the CA (valid --ca-days, 3650) and
#                                                            the governance; members and the revocation list
#                                                            are valid --days (365)
#   scripts/fleet-keys.sh add DIR robot ID                   a robot (ID 1..250): robot-ID
#   scripts/fleet-keys.sh add DIR base [NAME]                the base station (default name: base)
#   scripts/fleet-keys.sh add DIR viewer [NAME]              a read-only member (default: viewer)
#   scripts/fleet-keys.sh add DIR bench NAME                 cairn-bench-dds's topics only (the cost of security)
#   scripts/fleet-keys.sh renew DIR NAME                     NAME gets a new key and certificate (--days from
#                                                            now); the old certificate is revoked
#   scripts/fleet-keys.sh revoke DIR NAME                    NAME leaves the fleet: its certificate is revoked
#   scripts/fleet-keys.sh crl DIR                            sign the revocation list again (before it expires)
#   scripts/fleet-keys.sh list DIR                           the members and their roles
#
# Layout of DIR (the CA's key never leaves it: copy a member's directory, not DIR):
#   ca/ca.pem, ca/ca.key          the fleet CA (identity CA and permissions CA in one)
#   ca/openssl.cnf, index.txt ... the CA's record of what it issued and revoked (openssl ca)
#   crl.pem                       the certificate revocation list, signed by the CA
#   governance.xml, governance.p7s  what is protected: every topic, authenticated, encrypted
#   members/NAME/cert.pem key.pem   NAME's identity (key readable by its owner only)
#   members/NAME/permissions.xml .p7s  what NAME may publish and read (by role)
#   members/NAME/ca.pem governance.p7s crl.pem  copies: a member's directory is all its host needs
#   revoked/NAME                  a revoked member's old directory, kept for the record
#   revoked/NAME.SERIAL           a renewed member's old certificate (its key deleted)
# After a revoke, every member's crl.pem is replaced here; copy the members' directories
# to their hosts again: a member refuses a peer whose certificate its crl.pem lists. The
# list itself expires after --days: sign it again before (crl) and copy it out likewise.
set -euo pipefail

die() { echo "fleet-keys: $*" >&2; exit 2; }
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d'; }
command -v openssl >/dev/null || die "openssl is needed (apt-get install openssl)"

# The topics by role (common/dds/topics.hpp is the list's source; a test checks they agree).
robot_publishes="cairn_robot_status cairn_odometry cairn_laser_scan cairn_features cairn_bid"
robot_reads="cairn_task cairn_pose_correction cairn_safety_reset cairn_safety_stop cairn_map_tile cairn_feature_map"
base_publishes="cairn_task cairn_pose_correction cairn_safety_reset cairn_safety_stop cairn_map_tile cairn_feature_map cairn_visit_request"
bench_topics="bench_ping bench_pong bench_data"  # tests/bench/dds_bench.cpp
# A robot publishes its topics only in its own partition, PREFIX<id>, and the base and the
# viewer read them in PREFIX* (common/dds/partition.hpp's kRobotPartitionPrefix; a test
# checks they agree). A rule without <partitions> covers only the default partition.
robot_partition_prefix="cairn-robot-"

org="Cairn fleet"
subject() { echo "/O=$org/CN=$1"; }
dn() { echo "CN=$1,O=$org"; }  # the permissions' subject_name (RFC 4514 order)

sign() {  # sign XML -> S/MIME (what the DDS Security access control plugin reads)
  openssl smime -sign -in "$2" -text -out "$3" -signer "$1/ca/ca.pem" -inkey "$1/ca/ca.key" 2>/dev/null ||
    die "signing $2 failed"
}

gencrl() {  # DIR: the CRL from the CA's record, copied to every member
  openssl ca -batch -config "$1/ca/openssl.cnf" -gencrl -out "$1/crl.pem" 2>/dev/null || die "writing the CRL failed"
  local m
  for m in "$1"/members/*/; do [[ -d $m ]] && cp "$1/crl.pem" "$m/crl.pem"; done
  return 0
}

issue() {  # DIR NAME ROLE DEST: a new key, certificate and signed permissions for NAME in DEST
  local dir=$1 name=$2 role=$3 m=$4 domain days
  domain=$(cat "$dir/domain") days=$(cat "$dir/days")
  rm -rf "$m"
  mkdir -p "$m"
  (umask 077; openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj "$(subject "$name")" \
    -keyout "$m/key.pem" -out "$m/req.pem" 2>/dev/null) || { rm -rf "$m"; die "creating $name's key failed"; }
  openssl ca -batch -notext -config "$dir/ca/openssl.cnf" -in "$m/req.pem" -out "$m/cert.pem" 2>/dev/null ||
    { rm -rf "$m"; die "signing $name's certificate failed"; }
  rm -f "$m/req.pem"
  echo "$role" > "$m/role"
  permissions_xml "$name" "$role" "$domain" "$(date -u +%Y-%m-%dT%H:%M:%S)" \
    "$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)" > "$m/permissions.xml"
  sign "$dir" "$m/permissions.xml" "$m/permissions.p7s"
  cp "$dir/ca/ca.pem" "$dir/governance.p7s" "$dir/crl.pem" "$m/"
}

topics_xml() { local t; for t in $1; do echo "            <topic>$t</topic>"; done; }
partition_xml() { echo "          <partitions><partition>$1</partition></partitions>"; }

permissions_xml() {  # NAME ROLE DOMAIN NOT_BEFORE NOT_AFTER
  local name=$1 role=$2 domain=$3
  cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>$(dn "$name")</subject_name>
      <validity><not_before>$4</not_before><not_after>$5</not_after></validity>
EOF
  case $role in
    robot) cat <<EOF
      <allow_rule>
        <domains><id>$domain</id></domains>
        <publish><topics>
$(topics_xml "$robot_publishes")
        </topics>
$(partition_xml "$robot_partition_prefix$((10#${name#robot-}))")
        </publish>
        <subscribe><topics>
$(topics_xml "$robot_reads")
        </topics></subscribe>
      </allow_rule>
EOF
    ;;
    base) cat <<EOF
      <allow_rule>
        <domains><id>$domain</id></domains>
        <publish><topics>
$(topics_xml "$base_publishes")
        </topics></publish>
        <subscribe><topics><topic>*</topic></topics></subscribe>
        <subscribe><topics>
$(topics_xml "$robot_publishes")
        </topics>
$(partition_xml "$robot_partition_prefix*")
        </subscribe>
      </allow_rule>
EOF
    ;;
    bench) cat <<EOF
      <allow_rule>
        <domains><id>$domain</id></domains>
        <publish><topics>
$(topics_xml "$bench_topics")
        </topics></publish>
        <subscribe><topics>
$(topics_xml "$bench_topics")
        </topics></subscribe>
      </allow_rule>
EOF
    ;;
    viewer) cat <<EOF
      <allow_rule>
        <domains><id>$domain</id></domains>
        <subscribe><topics><topic>*</topic></topics></subscribe>
        <subscribe><topics>
$(topics_xml "$robot_publishes")
        </topics>
$(partition_xml "$robot_partition_prefix*")
        </subscribe>
      </allow_rule>
EOF
    ;;
  esac
  cat <<EOF
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
}

governance_xml() {  # DOMAIN
  cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id>$1</id></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
}

cmd=${1:-}
[[ $cmd == -h || $cmd == --help || -z $cmd ]] && { usage; [[ -n $cmd ]]; exit $?; }
dir=${2:-}
[[ -n $dir ]] || die "$cmd: DIR missing (try --help)"
shift 2

case $cmd in
  init)
    domain=0 days=365 ca_days=3650
    while (($#)); do
      case $1 in
        --domain) domain=${2:?--domain N}; shift 2 ;;
        --days) days=${2:?--days N}; shift 2 ;;
        --ca-days) ca_days=${2:?--ca-days N}; shift 2 ;;
        *) die "init: unknown option '$1'" ;;
      esac
    done
    [[ $domain =~ ^[0-9]+$ ]] && ((domain <= 230)) || die "init: --domain must be 0..230, not '$domain'"
    [[ $days =~ ^[1-9][0-9]*$ ]] || die "init: --days must be a positive integer, not '$days'"
    [[ $ca_days =~ ^[1-9][0-9]*$ ]] && ((ca_days >= days)) || die "init: --ca-days must be an integer >= --days ($days), not '$ca_days'"
    [[ ! -e $dir/ca/ca.key ]] || die "init: $dir already holds a fleet CA (a new fleet needs a new directory)"
    mkdir -p "$dir/ca/issued" "$dir/members"
    dir=$(cd "$dir" && pwd)
    (umask 077; openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days "$ca_days" \
      -subj "$(subject "fleet CA")" -keyout "$dir/ca/ca.key" -out "$dir/ca/ca.pem" 2>/dev/null) || die "init: creating the CA failed"
    chmod 644 "$dir/ca/ca.pem"
    echo "$domain" > "$dir/domain"
    echo "$days" > "$dir/days"
    : > "$dir/ca/index.txt"
    echo 1000 > "$dir/ca/serial"
    echo 1000 > "$dir/ca/crlnumber"
    cat > "$dir/ca/openssl.cnf" <<EOF
[ ca ]
default_ca = fleet
[ fleet ]
dir = $dir/ca
database = \$dir/index.txt
new_certs_dir = \$dir/issued
certificate = \$dir/ca.pem
private_key = \$dir/ca.key
serial = \$dir/serial
crlnumber = \$dir/crlnumber
default_md = sha256
default_days = $days
default_crl_days = $days
policy = member
unique_subject = no
copy_extensions = none
[ member ]
organizationName = supplied
commonName = supplied
EOF
    gencrl "$dir"
    governance_xml "$domain" > "$dir/governance.xml"
    sign "$dir" "$dir/governance.xml" "$dir/governance.p7s"
    echo "fleet-keys: a new fleet in $dir (domain $domain, CA valid $ca_days days, members and revocation list $days days); add its members with: $0 add $dir robot ID | base | viewer"
    ;;
  add)
    [[ -f $dir/ca/ca.key ]] || die "add: $dir holds no fleet (run: $0 init $dir)"
    role=${1:-}
    case $role in
      robot)
        id=${2:-}
        [[ $id =~ ^[0-9]+$ ]] && ((id >= 1 && id <= 250)) || die "add robot: ID must be 1..250, not '${id}'"
        name="robot-$id" ;;
      base) name=${2:-base} ;;
      viewer) name=${2:-viewer} ;;
      bench) name=${2:?add bench NAME} ;;
      *) die "add: the role must be robot, base, viewer or bench, not '$role'" ;;
    esac
    [[ $name =~ ^[A-Za-z0-9._-]+$ ]] || die "add: a name is letters, digits, '.', '_' or '-', not '$name'"
    m="$dir/members/$name"
    [[ ! -e $m ]] || die "add: $name is already a member (renew it for a new certificate)"
    issue "$dir" "$name" "$role" "$m"
    echo "fleet-keys: $name ($role) added: $m (its configuration: [dds] keys = \"$m\", or that directory copied to its host)"
    ;;
  renew)
    name=${1:-}
    [[ $name =~ ^[A-Za-z0-9._-]+$ && $name != . && $name != .. && -d $dir/members/$name ]] ||
      die "renew: no member '$name' in $dir"
    m="$dir/members/$name"
    role=$(cat "$m/role")
    old_serial=$(openssl x509 -in "$m/cert.pem" -noout -serial | cut -d= -f2)
    issue "$dir" "$name" "$role" "$m.new"
    # The old certificate is revoked (superseded): a copy left on a host or a stolen card
    # stops working as soon as the members hold the new revocation list.
    openssl ca -batch -config "$dir/ca/openssl.cnf" -revoke "$m/cert.pem" -crl_reason superseded 2>/dev/null ||
      { rm -rf "$m.new"; die "renew: revoking $name's old certificate failed"; }
    mkdir -p "$dir/revoked"
    rm -rf "$dir/revoked/$name.$old_serial"
    mv "$m" "$dir/revoked/$name.$old_serial"
    rm -f "$dir/revoked/$name.$old_serial/key.pem"
    mv "$m.new" "$m"
    gencrl "$dir"
    echo "fleet-keys: $name renewed ($(openssl x509 -in "$m/cert.pem" -noout -enddate | sed 's/notAfter=/until /'); old certificate $old_serial revoked): copy $m to its host and the members' crl.pem to theirs"
    ;;
  revoke)
    name=${1:-}
    [[ $name =~ ^[A-Za-z0-9._-]+$ && $name != . && $name != .. && -d $dir/members/$name ]] ||
      die "revoke: no member '$name' in $dir"
    openssl ca -batch -config "$dir/ca/openssl.cnf" -revoke "$dir/members/$name/cert.pem" 2>/dev/null ||
      die "revoke: revoking $name's certificate failed"
    mkdir -p "$dir/revoked"
    rm -rf "$dir/revoked/$name"
    mv "$dir/members/$name" "$dir/revoked/$name"
    rm -f "$dir/revoked/$name/key.pem"  # the identity is dead: its key is of no use to anyone
    gencrl "$dir"
    echo "fleet-keys: $name revoked (its files: $dir/revoked/$name); copy the members' crl.pem to their hosts"
    ;;
  crl)
    [[ -f $dir/ca/ca.key ]] || die "crl: $dir holds no fleet"
    gencrl "$dir"
    echo "fleet-keys: $dir/crl.pem signed again ($(openssl crl -in "$dir/crl.pem" -noout -nextupdate)); copy the members' crl.pem to their hosts"
    ;;
  list)
    [[ -d $dir/members ]] || die "list: $dir holds no fleet"
    for m in "$dir"/members/*/; do
      [[ -d $m ]] || continue
      note=""
      openssl x509 -in "$m/cert.pem" -noout -checkend $((30 * 86400)) >/dev/null || note=" (ends within 30 days: renew it)"
      echo "$(basename "$m") $(cat "$m/role") $(openssl x509 -in "$m/cert.pem" -noout -enddate | sed 's/notAfter=/until /')$note"
    done
    end=$(openssl crl -in "$dir/crl.pem" -noout -nextupdate | cut -d= -f2)
    note=""
    (($(date -d "$end" +%s) < $(date +%s) + 30 * 86400)) && note=" (within 30 days: run crl)"
    echo "revocation list until $end$note"
    ;;
  *) die "unknown command '$cmd' (try --help)" ;;
esac
