#include "firmware/localmap/work_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace cairn::localmap {

// cairn-calibrate-localmap 101 on the build machine (AMD EPYC, 2 vCPU at 2.1 GHz, loaded
// by other builds; gcc 12 -O2), the highest of three runs: docs/localmap.md "Work budget".
const WorkCosts kCalibratedCosts{
    .search_tap_ns = 1.3,
    .index_ns = 5.5,
    .point_eval_ns = 15.0,
    .copy_ns = 1.0,  // measured 0.14 with the ring warm in cache; the RT thread's copy may find it cold
    .stamp_ns = 75.0,
    .stamp_tap_ns = 0.8,
    .cell_ns = 0.42,
};

namespace {
// Central differences of a 3-axis function: f0, 2 per axis, 4 per axis pair (ScanMatcher::finish).
constexpr double kCovarianceEvals = 1 + 2 * 3 + 4 * 3;
}  // namespace

WorkEstimate estimate_work(const LocalMapConfig& c, int beams, const WorkCosts& k) {
  WorkEstimate w;
  const double all = std::max(beams, 0);
  w.points = std::min(all, static_cast<double>(c.max_points));
  const SearchShape s = search_shape(c.grid, c.match);
  const double coarse_angles = 2.0 * s.coarse_angles + 1, coarse_side = 2.0 * s.coarse_shifts + 1;
  const double fine_angles = c.match.candidates * (2.0 * s.fine_angles + 1), fine_side = 2.0 * s.fine_shifts + 1;
  w.coarse_poses = coarse_angles * coarse_side * coarse_side;
  w.fine_poses = fine_angles * fine_side * fine_side;
  // decimate_m can leave every point (a scan along a wall at close range), so the worst case is all of them.
  w.search_taps = (w.coarse_poses + w.fine_poses) * w.points;
  w.index_ops = (coarse_angles + fine_angles) * w.points;
  // Refinement and covariance use every point of the scan, not only max_points.
  w.point_evals = (c.match.gn_iterations + 1 + kCovarianceEvals) * all;
  w.copies = c.keyframes * w.points;
  // A rebuild stamps every keyframe point, plus the points joining neighbours closer than
  // surface_gap_m every half cell: at most ceil(gap / step) - 2 per pair.
  const double step = 0.5 * c.grid.resolution_m;
  const double fill = c.surface_gap_m > step ? std::max(0.0, std::ceil(c.surface_gap_m / step) - 2) : 0.0;
  w.stamps = c.keyframes * (w.points + std::max(0.0, w.points - 1) * fill);
  const int r = kernel_radius_cells(c.grid);
  w.kernel_taps = (2 * r + 1) * (2 * r + 1);
  w.cells = static_cast<double>(c.grid.size_cells) * c.grid.size_cells;

  w.search_ms = (w.search_taps * k.search_tap_ns + w.index_ops * k.index_ns) * 1e-6;
  w.eval_ms = w.point_evals * k.point_eval_ns * 1e-6;
  w.copy_ms = c.async_rebuild ? w.copies * k.copy_ns * 1e-6 : 0.0;
  w.match_ms = w.search_ms + w.eval_ms + w.copy_ms;
  w.stamp_ms = w.stamps * (k.stamp_ns + w.kernel_taps * k.stamp_tap_ns) * 1e-6;
  w.cell_ms = w.cells * k.cell_ns * 1e-6;
  w.rebuild_ms = w.stamp_ms + w.cell_ms;
  return w;
}

double min_keyframe_interval_s(const LocalMapConfig& c, double max_v, double max_w) {
  const double inf = std::numeric_limits<double>::infinity();
  const double by_distance = max_v > 0 ? c.keyframe_distance_m / max_v : inf;
  const double by_angle = max_w > 0 ? c.keyframe_angle_rad / max_w : inf;
  return std::min(by_distance, by_angle);
}

std::string check_budget(const LocalMapConfig& c, int beams, const WorkBudget& b, const WorkCosts& k) {
  const WorkEstimate w = estimate_work(c, beams, k);
  char msg[512];
  const double rt_ms = b.rt_share * b.rt_period_s * 1e3;
  if (w.match_ms > rt_ms) {
    std::snprintf(msg, sizeof msg,
                  "worst-case per-scan matching %.1f ms (search %.1f ms: %.0f coarse + %.0f fine poses x %.0f points; "
                  "refinement and covariance %.1f ms: %.0f point evaluations) exceeds the budget %.1f ms "
                  "(%.0f %% of the %.1f ms RT period)",
                  w.match_ms, w.search_ms, w.coarse_poses, w.fine_poses, w.points, w.eval_ms, w.point_evals, rt_ms,
                  100 * b.rt_share, b.rt_period_s * 1e3);
    return msg;
  }
  const double worker_ms = b.worker_share * b.keyframe_interval_s * 1e3;
  if (w.rebuild_ms > worker_ms) {
    std::snprintf(msg, sizeof msg,
                  "worst-case keyframe rebuild %.1f ms (%.0f stamped points x %d kernel taps; %dx%d cells) exceeds "
                  "the rebuild worker's budget %.1f ms (%.0f %% of the %.0f ms between keyframes at full speed)",
                  w.rebuild_ms, w.stamps, w.kernel_taps, c.grid.size_cells, c.grid.size_cells, worker_ms,
                  100 * b.worker_share, b.keyframe_interval_s * 1e3);
    return msg;
  }
  return {};
}

}  // namespace cairn::localmap
