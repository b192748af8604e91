#!/usr/bin/env bash
# Chooses the task allocator's exchange rate (cells of expected gain per metre of path,
# cairn-base's [explore] cells_per_metre) on held-out worlds only: hil/worlds/tuning/ (a
# longer office than world A, and D's and E's kinds of random map with other seeds), never
# on worlds A-E, whose grid (scripts/explore-grid.sh) reports the result. For each rate,
# RUNS runs of each tuning world with 1, 2 and 3 robots in one shared world, as the grid
# runs them. Score: the mean over (world, robot count) of the mean time to 95 % coverage
# relative to the same at the first rate listed (a run that never reaches 95 % counts as
# the 1800 s cap); the lowest score wins. Writes OUT/tune.md and OUT/tune.json.
# The rate is set on both sides: the base's allocator and the robots' bids (which rank and
# cut their items with it). TUNE_REUSE=1 keeps a (rate, world) whose summary is already in
# OUT instead of running it again (only valid for the same code: the runs are deterministic).
#   scripts/explore-tune.sh [RUNS] [RATES] [OUT]   e.g. scripts/explore-tune.sh 3 "10 20 40"
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
rates=${2:-10 20 40}
out=${3:-build/explore-tune}
case "$runs" in ''|*[!0-9]*) echo "explore-tune: RUNS must be a whole number, not '$runs'" >&2; exit 2 ;; esac
for r in $rates; do
  [[ "$r" =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "explore-tune: a rate must be a number >= 0, not '$r'" >&2; exit 2; }
done
cmake --preset ci >/dev/null
cmake --build --preset ci --target cairn-eval >/dev/null
bin=build/ci/tools/eval/cairn-eval
mkdir -p "$out"
start=$(date +%s)
for rate in $rates; do
  for w in offices_long random15_tune random_clutter_tune; do
    extra=()
    [ "$w" = offices_long ] || extra=(--random-maps)
    if [ -n "${TUNE_REUSE:-}" ] && [ -f "$out/$rate/$w/summary.json" ]; then
      echo "== explore-tune: $rate cells/m, $w: kept from an earlier run (TUNE_REUSE)"
      continue
    fi
    echo "== explore-tune: $rate cells/m, $w, $(( $(date +%s) - start )) s so far"
    "$bin" explore --world "hil/worlds/tuning/$w.world" --robots 1,2,3 --runs "$runs" --seed 101 --shared-world \
      --duration 1800 --cells-per-metre "$rate" --out "$out/$rate/$w" "${extra[@]}" >/dev/null
  done
done
python3 - "$out" "$runs" "$(( $(date +%s) - start ))" $rates <<'PY'
import json, sys
out, runs, wall, rates = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
worlds = ["offices_long", "random15_tune", "random_clutter_tune"]
cap = 1800.0
t95 = {}  # (rate, world, robots) -> mean seconds to 95 %, the cap for a run that did not reach it
for rate in rates:
    for w in worlds:
        s = json.load(open(f"{out}/{rate}/{w}/summary.json"))
        by = {}
        for r in s["runs"]:
            t = r["time_to_coverage_s"]["95"]
            by.setdefault(r["robots"], []).append(cap if t is None else t)
        for n, ts in by.items():
            t95[(rate, w, n)] = sum(ts) / len(ts)
keys = sorted({(w, n) for (_, w, n) in t95})
score = {rate: sum(t95[(rate, w, n)] / t95[(rates[0], w, n)] for (w, n) in keys) / len(keys) for rate in rates}
best = min(rates, key=lambda r: score[r])
lines = [f"Made by `scripts/explore-tune.sh {runs} \"{' '.join(rates)}\"` in {wall} s wall: mean simulated seconds to 95 % "
         f"coverage over {runs} runs (seeds 101..), 1 / 2 / 3 robots in one shared world; a run that never reached 95 % counts "
         f"as {cap:.0f} s. Score: mean of the times relative to {rates[0]} cells/m (lower is better).", "",
         "| cells/m | " + " | ".join(f"{w} (1 / 2 / 3)" for w in worlds) + " | score |",
         "|---" * (len(worlds) + 2) + "|"]
for rate in rates:
    cells = [" / ".join(f"{t95[(rate, w, n)]:.0f}" for n in (1, 2, 3)) for w in worlds]
    lines.append(f"| {rate} | " + " | ".join(cells) + f" | {score[rate]:.3f} |")
lines += ["", f"Lowest score: {best} cells/m."]
open(f"{out}/tune.md", "w").write("\n".join(lines) + "\n")
json.dump({"runs": runs, "rates": rates, "score": score, "best": best,
           "t95": {f"{r}/{w}/{n}": v for (r, w, n), v in t95.items()}, "wall_seconds": wall},
          open(f"{out}/tune.json", "w"), indent=2)
print("\n".join(lines))
PY
