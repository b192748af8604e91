#!/usr/bin/env bash
# Runs Cairn's benchmarks beside their peer baselines, in one go, and prints the ratios.
# Installs the peers first (MRPT from Debian: scripts/setup-deps.sh --peers).
#   scripts/bench.sh [dds|lms|ccml|scans|all]   (default all)
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
scripts/setup-deps.sh --peers
scripts/build.sh release >/dev/null
B=build/release/tests/bench
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"   # DDS stays on loopback
if [[ $what == dds || $what == all ]]; then
  echo "== DDS: Cairn's layer vs Cyclone's ddsperf (10 s each)"
  tests/bench/dds_vs_ddsperf.sh "$B/cairn-bench-dds" 10
fi
if [[ $what == lms || $what == all ]]; then
  echo "== LMS2xx codec: CRC baseline, stream throughput, per-scan latency"
  "$B/cairn-bench-lms-codec"
fi
if [[ $what == ccml || $what == all ]]; then
  echo "== CCML: Cairn's EKF vs MRPT's CRangeBearingKFSLAM2D"
  "$B/cairn-bench-ccml-mrpt" --steps 200 --mrclam data/mrclam/MRCLAM_Dataset6
  echo "== CCML: twenty robots into the base's fusion at their real rates (symmetric vs Joseph update)"
  "$B/cairn-bench-fleet-fusion" --robots 20 --landmarks 300 --seconds 20 --warmup 40
fi
if [[ $what == scans || $what == all ]]; then
  echo "== Scan matching: Cairn's matcher vs MRPT ICP on the Intel and ACES Carmen logs"
  C=data/radish-corrected-carmen
  "$B/cairn-bench-scan-mrpt" "$C/intel-corrected.log.gz" "$C/aces-corrected.log.gz"
fi
