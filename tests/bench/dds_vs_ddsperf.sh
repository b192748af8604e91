#!/usr/bin/env bash
# Round-trip latency and throughput of Cairn's DDS layer beside Cyclone's own
# ddsperf, in the same run, on the loopback profile. Prints both and the ratios.
#   tests/bench/dds_vs_ddsperf.sh BENCH_BINARY [SECONDS]
set -euo pipefail
bench=$1
secs=${2:-5}
here=$(cd "$(dirname "$0")/../.." && pwd)
export CYCLONEDDS_URI="file://$here/config/dds/loopback.xml"
command -v ddsperf >/dev/null || { echo "ddsperf not found (Debian package cyclonedds-tools)"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"; kill $(jobs -p) 2>/dev/null || true' EXIT

# Latency: ping/pong, waitset-triggered, ~128-byte samples, two processes each.
ddsperf -i 140 -D $((secs + 2)) pong waitset >/dev/null 2>&1 &
sleep 0.3
ddsperf -i 140 -D "$secs" ping size 128 waitset >"$tmp/ddsperf_ping" 2>&1
wait
"$bench" pong --domain 141 --duration $((secs + 2)) &
sleep 0.3
"$bench" ping --domain 141 --duration "$secs" >"$tmp/cairn_ping"
wait

# Throughput: pub/sub, reliable, ~128-byte samples.
ddsperf -i 142 -D $((secs + 2)) sub >"$tmp/ddsperf_sub" 2>&1 &
sleep 0.3
ddsperf -i 142 -D "$secs" pub size 128 >/dev/null 2>&1
wait
"$bench" sub --domain 143 --duration $((secs + 2)) >"$tmp/cairn_sub" &
sleep 0.3
"$bench" pub --domain 143 --duration "$secs"
wait

# ddsperf prints one line per second; take the mean over the run's full seconds.
dp_lat=$(grep -E ' size 128 mean ' "$tmp/ddsperf_ping" | awk '{for(i=1;i<=NF;i++){if($i=="50%"){s+=$(i+1)+0;n++}}} END{if(n) printf "%.3f", s/n}')
dp_lat99=$(grep -E ' size 128 mean ' "$tmp/ddsperf_ping" | awk '{for(i=1;i<=NF;i++){if($i=="99%"){s+=$(i+1)+0;n++}}} END{if(n) printf "%.3f", s/n}')
# ddsperf's own whole-run average is the parenthesised rate on its last line.
dp_rate=$(grep -E ' size 128 total ' "$tmp/ddsperf_sub" | tail -1 | sed -E 's/.*\(([0-9.]+) kS\/s.*/\1/')
c_lat=$(awk '{for(i=1;i<=NF;i++) if($i=="50%") print $(i+1)+0}' "$tmp/cairn_ping")
c_lat99=$(awk '{for(i=1;i<=NF;i++) if($i=="99%") print $(i+1)+0}' "$tmp/cairn_ping")
c_rate=$(awk '{for(i=1;i<=NF;i++) if($i=="rate") print $(i+1)}' "$tmp/cairn_sub")

echo "ddsperf: $(grep -E ' size 128 mean ' "$tmp/ddsperf_ping" | tail -1)"
echo "cairn:   $(cat "$tmp/cairn_ping")"
echo "ddsperf: $(grep -E ' size 128 total ' "$tmp/ddsperf_sub" | tail -1)"
echo "cairn:   $(cat "$tmp/cairn_sub")"
printf '\n%-28s %12s %12s %8s\n' "metric" "ddsperf" "cairn" "ratio"
printf '%-28s %12s %12s %8.2f\n' "round trip p50 (us)" "$dp_lat" "$c_lat" "$(echo "$c_lat / $dp_lat" | bc -l)"
printf '%-28s %12s %12s %8.2f\n' "round trip p99 (us)" "$dp_lat99" "$c_lat99" "$(echo "$c_lat99 / $dp_lat99" | bc -l)"
printf '%-28s %12s %12s %8.2f\n' "throughput (kS/s)" "$dp_rate" "$c_rate" "$(echo "$c_rate / $dp_rate" | bc -l)"
echo "(ratio = cairn / ddsperf: latency < 1 is better, throughput > 1 is better)"
