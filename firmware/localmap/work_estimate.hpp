// Worst-case work of the local mapper, from the configuration alone: a count of the
// inner-loop operations each stage can do at most, times a calibrated cost per operation
// (ns). Matching runs once per scan on the RT thread; the keyframe rebuild runs on the
// rebuild worker (LocalMapConfig::async_rebuild). check_budget() refuses a configuration
// whose estimate does not fit. The model and its calibration: docs/localmap.md.
#pragma once

#include <string>

#include "firmware/localmap/local_mapper.hpp"

namespace cairn::localmap {

/// Cost of one operation of each kind, in ns. Measured by cairn-calibrate-localmap
/// (tests/bench/localmap_calibrate.cpp); kCalibratedCosts holds the figures of the
/// machine docs/localmap.md names.
struct WorkCosts {
  double search_tap_ns;    // one point scored at one pose of the correlative search (a cell read and an add)
  double index_ns;         // one point rotated and binned for one search angle
  double point_eval_ns;    // one point in one Gauss-Newton or covariance evaluation (bilinear sample)
  double copy_ns;          // one keyframe point copied into the rebuild request (async mode, RT side)
  double stamp_ns;         // one point stamped in the rebuild, beside its taps (its kernel weights: 2 (2 r + 1) exp)
  double stamp_tap_ns;     // one kernel tap of one stamped point in the rebuild
  double cell_ns;          // one fine cell cleared and max-pooled in the rebuild
};
extern const WorkCosts kCalibratedCosts;

struct WorkEstimate {
  // Operation counts (worst case).
  double points = 0;         // per scan into the searches and keyframes: min(beams, max_points)
  double coarse_poses = 0, fine_poses = 0, search_taps = 0, index_ops = 0;
  double point_evals = 0;    // (gn_iterations + 1 + 19 covariance) × beams
  double copies = 0;         // keyframes × points
  double stamps = 0;         // keyframes × (points + gap fill), each (2 r + 1)² taps
  int kernel_taps = 0;
  double cells = 0;          // size_cells²
  // Times (ms).
  double search_ms = 0, eval_ms = 0, copy_ms = 0, match_ms = 0;  // match_ms: the RT thread's per-scan work
  double stamp_ms = 0, cell_ms = 0, rebuild_ms = 0;              // the worker's per-keyframe work
};

/// The worst case for scans of `beams` points (the laser's beams per scan).
WorkEstimate estimate_work(const LocalMapConfig& c, int beams, const WorkCosts& k = kCalibratedCosts);

struct WorkBudget {
  double rt_period_s = 0.01;
  double rt_share = 0.5;            // of the RT period the matching may take
  double keyframe_interval_s = 0.1; // shortest time between keyframes (at full speed or turn rate)
  double worker_share = 0.5;        // of that interval a rebuild may take
};

/// The shortest time between keyframes at these speed limits (m/s, rad/s; 0 = no motion).
double min_keyframe_interval_s(const LocalMapConfig& c, double max_v, double max_w);

/// Empty when the estimate fits both budgets; otherwise why not, with the numbers.
std::string check_budget(const LocalMapConfig& c, int beams, const WorkBudget& b,
                         const WorkCosts& k = kCalibratedCosts);

}  // namespace cairn::localmap
