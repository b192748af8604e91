// How the MRCLAM noise parameters are chosen, written down as code (docs/ccml.md):
//  1. Measurements: every landmark sighting in the calibration window is compared with
//     the range and bearing predicted from the robot's ground-truth pose and the
//     landmark's surveyed position; σ is the robust spread of the residuals about zero
//     (1.4826 × median |residual|), so the outliers the filter gates do not inflate it.
//  2. Odometry: over windows of `window_s`, the commanded velocities integrated as the
//     filter integrates them are compared with the ground-truth motion in the robot's
//     frame; the filter's per-step variance model (a relative term per step plus a rate
//     floor) summed over each window is fitted to the squared residuals by non-negative
//     least squares, for translation (x) and for heading.
//  3. Consistency: commanded velocity is not what the wheels did, and its errors are
//     correlated in time, which step 2's white model cannot see. One factor on the
//     odometry σ's is chosen from a grid so that the labelled cooperative run over the
//     calibration window has mean pose NEES closest to 3 (its degrees of freedom).
// Only ground truth before `until_s` is used; results are scored after it (score_from).
#pragma once

#include <cstddef>

#include "tools/datasets/mrclam.hpp"

namespace cairn::ccml {

struct MrclamNoiseFit {
  double until_s = 0;  // calibration window [start, start + until_s)
  double window_s = 1.0;
  std::size_t measurements = 0;
  double range_sigma = 0, bearing_sigma = 0;  // step 1
  double range_median = 0, bearing_median = 0;  // biases, reported only
  std::size_t odometry_windows = 0;
  double odom_v_rel = 0, odom_v_rate = 0, odom_w_rel = 0, odom_w_rate = 0;  // step 2, before the factor
  double odometry_factor = 1;  // step 3
  double calibration_nees = -1;  // mean pose NEES over the calibration window with the factor
};

/// Steps 1-3 on `data` (which must have robot ground truth). Throws std::invalid_argument
/// when it has none or the window holds too little to fit.
MrclamNoiseFit calibrate_mrclam(const MrclamData& data, double until_s, double window_s = 1.0);

/// The fitted parameters (odometry σ's times the factor) in `options`.
void apply_noise(const MrclamNoiseFit& fit, MrclamOptions* options);

}  // namespace cairn::ccml
