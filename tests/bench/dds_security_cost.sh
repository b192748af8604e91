#!/usr/bin/env bash
# The cost of DDS Security (issue 20; docs/security.md): cairn-bench-dds's round trip and
# throughput on the loopback profile, plain and secured (secure-loopback: PKI-DH,
# access control, AES-GCM on every topic), in one run; the secured figures as ratios of
# the plain ones. Exit 1 when a run gives no figure.
#   tests/bench/dds_security_cost.sh BENCH_BINARY [SECONDS] [--json]
set -euo pipefail
bench=$1
secs=${2:-5}
json=0
[[ ${3:-} == --json ]] && json=1
here=$(cd "$(dirname "$0")/../.." && pwd)
export CYCLONEDDS_URI="file://$here/config/dds/loopback.xml"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"; kill $(jobs -p) 2>/dev/null || true' EXIT
domain=150
"$here/scripts/fleet-keys.sh" init "$tmp/keys" --domain $domain >/dev/null
"$here/scripts/fleet-keys.sh" add "$tmp/keys" bench a >/dev/null
"$here/scripts/fleet-keys.sh" add "$tmp/keys" bench b >/dev/null

# One pass: KIND ("plain" or "secure"), the keys options of the two sides.
pass() {
  local kind=$1 a=$2 b=$3
  # shellcheck disable=SC2086
  "$bench" pong --domain $domain --duration $((secs + 3)) $b &
  sleep 0.3
  # shellcheck disable=SC2086
  "$bench" ping --domain $domain --duration "$secs" $a >"$tmp/$kind.ping" || { echo "dds_security_cost: $kind ping failed" >&2; exit 1; }
  wait
  # shellcheck disable=SC2086
  "$bench" sub --domain $domain --duration $((secs + 3)) $b >"$tmp/$kind.sub" &
  sleep 0.3
  # shellcheck disable=SC2086
  "$bench" pub --domain $domain --duration "$secs" $a || { echo "dds_security_cost: $kind pub failed" >&2; exit 1; }
  wait
}
pass plain "" ""
pass secure "--keys $tmp/keys/members/a" "--keys $tmp/keys/members/b"

field() { awk -v k="$2" '{for(i=1;i<=NF;i++) if($i==k) print $(i+1)+0}' "$tmp/$1"; }
for kind in plain secure; do
  declare "${kind}_p50=$(field $kind.ping 50%)" "${kind}_p99=$(field $kind.ping 99%)" "${kind}_rate=$(field $kind.sub rate)"
done
for v in plain_p50 plain_p99 plain_rate secure_p50 secure_p99 secure_rate; do
  [[ -n ${!v} && ${!v} != 0 ]] || { echo "dds_security_cost: no figure for $v" >&2; cat "$tmp"/*.ping "$tmp"/*.sub >&2; exit 1; }
done
ratio() { echo "$1 / $2" | bc -l | xargs printf '%.3f'; }
r_p50=$(ratio "$secure_p50" "$plain_p50") r_p99=$(ratio "$secure_p99" "$plain_p99") r_rate=$(ratio "$secure_rate" "$plain_rate")
if ((json)); then
  printf '{"seconds": %s, "plain": {"round_trip_p50_us": %s, "round_trip_p99_us": %s, "throughput_kS_s": %s}, ' \
    "$secs" "$plain_p50" "$plain_p99" "$plain_rate"
  printf '"secure": {"round_trip_p50_us": %s, "round_trip_p99_us": %s, "throughput_kS_s": %s}, ' \
    "$secure_p50" "$secure_p99" "$secure_rate"
  printf '"ratio_secure_over_plain": {"round_trip_p50": %s, "round_trip_p99": %s, "throughput": %s}}\n' \
    "$r_p50" "$r_p99" "$r_rate"
else
  printf '%-24s %12s %12s %8s\n' "metric" "plain" "secure" "ratio"
  printf '%-24s %12s %12s %8s\n' "round trip p50 (us)" "$plain_p50" "$secure_p50" "$r_p50"
  printf '%-24s %12s %12s %8s\n' "round trip p99 (us)" "$plain_p99" "$secure_p99" "$r_p99"
  printf '%-24s %12s %12s %8s\n' "throughput (kS/s)" "$plain_rate" "$secure_rate" "$r_rate"
  echo "(ratio = secure / plain: latency > 1 and throughput < 1 are the cost)"
fi
