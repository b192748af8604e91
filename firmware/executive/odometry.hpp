// Differential-drive odometry from the drives' encoder positions, with covariance: each
// wheel's travel has variance k² · |travel| (+ a floor), propagated through the arc
// model's Jacobian; increments compose with their covariances. Pure, allocation-free.
#pragma once

#include <cstdint>

#include "common/se2.hpp"
#include "drivers/canopen/diff_drive.hpp"

namespace cairn::firmware {

struct OdometryNoise {
  double k_per_sqrt_m = 0.02;   // wheel travel sigma = k * sqrt(|travel|)
  double floor_m = 1e-4;        // per step
};

struct OdometryStep {
  Pose2 delta;        // robot frame at the previous sample
  Mat3 covariance = Mat3::Zero();
  double distance = 0;
};

class DiffOdometry {
 public:
  DiffOdometry(const canopen::DiffDriveGeometry& g, const OdometryNoise& n) : g_(g), n_(n) {}
  /// Encoder positions (drive increments, as the drives report them). The first call
  /// only latches them and returns a zero step.
  OdometryStep update(std::int32_t left_counts, std::int32_t right_counts);
  void reset() { primed_ = false; }

 private:
  canopen::DiffDriveGeometry g_;
  OdometryNoise n_;
  bool primed_ = false;
  std::int32_t left_ = 0, right_ = 0;
};

/// The arc increment for wheel travels dl, dr and its 3×2 Jacobian.
Pose2 arc_from_wheels(double dl, double dr, double track, Eigen::Matrix<double, 3, 2>* jacobian);

/// Accumulates increments: acc ⊕ step, covariance propagated.
void accumulate(OdometryStep* acc, const OdometryStep& step);

/// Splits an arc step at fraction f ∈ [0, 1] of its travel: `head` is the first f of the
/// same constant-curvature arc, `tail` the rest (head ⊕ tail = step); covariance and
/// distance are shared in proportion. Lets a scan take the odometry up to its own time
/// even when one wheel sample spans it (the RT loop woke late and merged several).
void split_step(const OdometryStep& step, double f, OdometryStep* head, OdometryStep* tail);

}  // namespace cairn::firmware
