// A base fusion with robot 1 localised at (1, 2, theta) with σ 0.1 / 0.2 m (its 3σ
// ellipse: semi-axes 0.6 m along y and 0.3 m), after one exact odometry step: what the web
// view's and Foxglove's state builders are tested on.
#pragma once

#include <gtest/gtest.h>

#include "basestation/fusion.hpp"

namespace cairn::testing {

inline base::Fusion localised_fusion(double theta = 0.0) {
  base::FusionConfig cfg;
  base::RobotPrior p;
  p.known = true;
  p.pose = {1.0, 2.0, theta};
  p.sigma = Vec3(0.1, 0.2, 0.01);
  cfg.robots[1] = p;
  base::Fusion f(cfg);
  msg::OdometryIncrement o;
  o.robot_id = 1;
  o.seq = 1;
  o.t0 = 0;
  o.t1 = 10 * kNanosPerMilli;
  o.delta_cov = {1e-12, 0, 0, 0, 1e-12, 0, 0, 0, 1e-12};
  o.boot_epoch = 7;
  EXPECT_EQ(f.on_odometry(o), base::Fusion::Result::kApplied);
  return f;
}

}  // namespace cairn::testing
