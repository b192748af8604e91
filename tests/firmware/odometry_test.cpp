// Wheel odometry steps: splitting a step at a fraction of its travel gives the same arc the
// wheels would have made over that fraction (forward, reverse, turning in place), the two
// parts compose back to the step, and covariance and distance are shared in proportion.
#include <gtest/gtest.h>

#include <cmath>

#include "firmware/executive/odometry.hpp"

namespace cairn::firmware {
namespace {

constexpr double kTrack = 0.5;

OdometryStep arc_step(double dl, double dr) {
  OdometryStep s;
  Eigen::Matrix<double, 3, 2> j;
  s.delta = arc_from_wheels(dl, dr, kTrack, &j);
  s.covariance = j * Eigen::Vector2d(1e-4 * std::abs(dl) + 1e-8, 1e-4 * std::abs(dr) + 1e-8).asDiagonal() * j.transpose();
  s.distance = std::abs(0.5 * (dl + dr));
  return s;
}

void expect_pose_near(const Pose2& a, const Pose2& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(normalize_angle(a.theta - b.theta), 0.0, tol);
}

TEST(OdometrySplit, HeadIsTheArcOfTheFractionAndPartsComposeBack) {
  const double wheels[][2] = {{0.10, 0.10}, {0.08, 0.12}, {-0.09, -0.05}, {-0.05, 0.05}, {0.3, -0.1}, {0.0, 0.0}};
  for (const auto& w : wheels) {
    for (const double f : {0.0, 0.25, 0.5, 0.9, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "dl " << w[0] << " dr " << w[1] << " f " << f);
      const OdometryStep step = arc_step(w[0], w[1]);
      OdometryStep head, tail;
      split_step(step, f, &head, &tail);
      expect_pose_near(head.delta, arc_from_wheels(f * w[0], f * w[1], kTrack, nullptr), 1e-12);
      // The wheel model takes the chord as ds long (not ds·sinc h), so the remainder agrees
      // with the model's own (1-f) arc to second order in the heading change only.
      const double h = 0.5 * (w[1] - w[0]) / kTrack, ds = 0.5 * (w[0] + w[1]);
      expect_pose_near(tail.delta, arc_from_wheels((1 - f) * w[0], (1 - f) * w[1], kTrack, nullptr), std::abs(ds) * h * h / 2 + 1e-12);
      expect_pose_near(compose(head.delta, tail.delta), step.delta, 1e-12);
      EXPECT_TRUE((head.covariance + tail.covariance).isApprox(step.covariance, 1e-12));
      EXPECT_NEAR(head.distance + tail.distance, step.distance, 1e-15);
      EXPECT_NEAR(head.distance, f * step.distance, 1e-15);
    }
  }
}

TEST(OdometrySplit, FractionOutsideTheStepIsClamped) {
  const OdometryStep step = arc_step(0.1, 0.12);
  OdometryStep head, tail;
  split_step(step, 1.7, &head, &tail);
  expect_pose_near(head.delta, step.delta, 1e-12);
  EXPECT_NEAR(tail.distance, 0.0, 1e-15);
  split_step(step, -0.3, &head, &tail);
  expect_pose_near(tail.delta, step.delta, 1e-12);
  EXPECT_EQ(head.distance, 0.0);
}

}  // namespace
}  // namespace cairn::firmware
