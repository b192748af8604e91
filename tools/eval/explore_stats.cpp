#include "tools/eval/explore_stats.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace cairn::eval {

bool is_failure(const ExploreRun& r) { return !(r.agreement >= kFailureAgreement); }

std::string level_name(std::size_t level) {
  return std::to_string(static_cast<int>(std::lround(kExploreLevels[level] * 100)));
}

namespace {

LevelStats level_stats(const std::vector<const ExploreRun*>& runs, std::size_t k) {
  LevelStats s;
  double sum = 0, lo = 0, hi = 0;
  for (const ExploreRun* r : runs) {
    if (!r->time_to[k]) continue;
    const double t = *r->time_to[k];
    lo = s.reached ? std::min(lo, t) : t;
    hi = s.reached ? std::max(hi, t) : t;
    sum += t;
    ++s.reached;
  }
  if (s.reached == 0) return s;
  const double mean = sum / static_cast<double>(s.reached);
  s.mean = mean;
  s.min = lo;
  s.max = hi;
  if (s.reached >= 2) {
    double ss = 0;
    for (const ExploreRun* r : runs) {
      if (r->time_to[k]) ss += (*r->time_to[k] - mean) * (*r->time_to[k] - mean);
    }
    s.sd = std::sqrt(ss / static_cast<double>(s.reached - 1));
  }
  return s;
}

// The run's coverage at time t: the last recorded value at or before t (0 before the first).
double coverage_at(const ExploreRun& r, double t) {
  const auto it = std::upper_bound(r.curve_t.begin(), r.curve_t.end(), t);
  if (it == r.curve_t.begin()) return 0;
  return r.curve_coverage[static_cast<std::size_t>(it - r.curve_t.begin()) - 1];
}

}  // namespace

std::vector<ExploreGroup> aggregate(const std::vector<ExploreRun>& runs, double curve_period_s, double until_s) {
  std::map<std::pair<int, int>, std::vector<const ExploreRun*>> by;  // (uncoordinated?, robots)
  for (const ExploreRun& r : runs) by[{r.mode == "coordinated" ? 0 : 1, r.robots}].push_back(&r);
  std::vector<ExploreGroup> out;
  for (const auto& [key, group] : by) {
    ExploreGroup g;
    g.mode = group.front()->mode;
    g.robots = key.second;
    g.runs = group.size();
    double explored_sum = 0;
    for (const ExploreRun* r : group) {
      if (r->explored) {
        ++g.completed;
        explored_sum += r->explored_at_s;
      }
      if (is_failure(*r)) ++g.failures;
      g.coverage_mean += r->final_coverage;
      g.drivable_mean += r->final_drivable;
      g.agreement_mean += r->agreement;
      g.bump_steps += r->bump_steps;
      if (r->closest_approach_m && (!g.closest_approach_min_m || *r->closest_approach_m < *g.closest_approach_min_m)) {
        g.closest_approach_min_m = r->closest_approach_m;
      }
    }
    g.coverage_mean /= static_cast<double>(g.runs);
    g.drivable_mean /= static_cast<double>(g.runs);
    g.agreement_mean /= static_cast<double>(g.runs);
    if (g.completed) g.explored_at_mean = explored_sum / static_cast<double>(g.completed);
    for (std::size_t k = 0; k < 4; ++k) g.level[k] = level_stats(group, k);
    if (curve_period_s > 0) {
      for (double t = 0; t <= until_s + 1e-9; t += curve_period_s) {
        double sum = 0, lo = 1, hi = 0;
        for (const ExploreRun* r : group) {
          const double c = coverage_at(*r, t);
          sum += c;
          lo = std::min(lo, c);
          hi = std::max(hi, c);
        }
        g.curve_t.push_back(t);
        g.curve_mean.push_back(sum / static_cast<double>(group.size()));
        g.curve_min.push_back(lo);
        g.curve_max.push_back(hi);
      }
    }
    out.push_back(std::move(g));
  }
  return out;
}

std::optional<double> speedup(const ExploreGroup& slow, const ExploreGroup& fast, std::size_t level) {
  const LevelStats& a = slow.level[level];
  const LevelStats& b = fast.level[level];
  if (a.reached != slow.runs || b.reached != fast.runs || !a.mean || !b.mean || *b.mean <= 0) return std::nullopt;
  return *a.mean / *b.mean;
}

}  // namespace cairn::eval
