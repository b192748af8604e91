// The pure-pursuit follower: it drives a unicycle to the end of a path, and a looped path
// whose waypoints all lie within reach holds the robot still instead of spinning for ever;
// its lookahead grows with speed, so it steers back to the line more gently when fast.
#include <gtest/gtest.h>

#include <vector>

#include "firmware/executive/path_follower.hpp"

namespace cairn::firmware {
namespace {

TEST(PathFollower, DrivesAUnicycleToTheEndOfAnLShapedPath) {
  PathFollower f({Vec2(3, 0), Vec2(3, 2)}, FollowerConfig{});
  Pose2 pose;
  double v = 0, w = 0;
  int steps = 0;
  for (; steps < 5000 && f.command(pose, v, &v, &w); ++steps) pose = compose(pose, arc_motion(v, w, 0.02));
  EXPECT_TRUE(f.done());
  EXPECT_LT(steps, 5000);
  EXPECT_LT((pose.translation() - Vec2(3, 2)).norm(), 0.35);  // within reach of the last waypoint
}

// cairn-sim gave a robot without a route a loop of one waypoint at its start: the first
// command() never returned.
TEST(PathFollower, ALoopWithEveryWaypointWithinReachHoldsStill) {
  FollowerConfig c;
  c.loop = true;
  PathFollower one({Vec2(0, 0)}, c);
  double v = 1, w = 1;
  EXPECT_TRUE(one.command(Pose2{}, 0.0, &v, &w));
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(w, 0.0);
  PathFollower three({Vec2(0.05, 0), Vec2(0, 0.05), Vec2(-0.05, 0)}, c);
  EXPECT_TRUE(three.command(Pose2{}, 0.0, &v, &w));
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(w, 0.0);
  // Out of reach again, it drives on.
  EXPECT_TRUE(three.command(Pose2{-2, 0, 0}, 0.0, &v, &w));
  EXPECT_NE(v + w, 0.0);
}

// 0.3 m beside a long straight path, heading along it: the curvature back to the line is
// 2y/L², so at 0.8 m/s (L = 0.96 m) it is a third of that at 0.2 m/s (L = 0.3 m, the
// minimum). A fixed lookahead gave both the same.
TEST(PathFollower, TheLookaheadGrowsWithSpeedSoFastRobotsSteerGently) {
  FollowerConfig c;
  c.speed = 1.0;
  c.max_w = 10;  // the turn-rate cap is not the subject
  const auto curvature = [&](double speed_now) {
    PathFollower f({Vec2(0, 0), Vec2(20, 0)}, c);
    double v = 0, w = 0;
    EXPECT_TRUE(f.command(Pose2{0.1, 0.0, 0.0}, speed_now, &v, &w));  // passes (0, 0): segment from it
    EXPECT_TRUE(f.command(Pose2{2.0, 0.3, 0.0}, speed_now, &v, &w));
    EXPECT_GT(v, 0.0);
    EXPECT_LT(w, 0.0) << "turning back towards the line";
    return std::abs(w / v);
  };
  const double slow = curvature(0.2), fast = curvature(0.8);
  EXPECT_NEAR(slow, 2 * 0.3 / (0.3 * 0.3 + 0.3 * 0.3), 1e-6);  // target (2.3, 0): 0.3 ahead, 0.3 beside
  EXPECT_NEAR(fast, 2 * 0.3 / (0.96 * 0.96 + 0.3 * 0.3), 1e-6);
  EXPECT_LT(fast, 0.5 * slow);
}

// The pass radius is half the lookahead at cruise speed, whatever the speed now: a robot
// slowing near a waypoint must not have to creep up to it.
TEST(PathFollower, AWaypointIsPassedAtTheSameDistanceWhateverTheSpeedNow) {
  FollowerConfig c;  // cruise 0.5 m/s: lookahead 0.6 m, pass radius 0.3 m
  for (double speed_now : {0.0, 0.1, 1.0}) {
    PathFollower f({Vec2(2, 0), Vec2(2, 2)}, c);
    double v = 0, w = 0;
    EXPECT_TRUE(f.command(Pose2{1.72, 0.0, 0.0}, speed_now, &v, &w));
    EXPECT_EQ(f.target_index(), 1u) << "at " << speed_now << " m/s";
    PathFollower g({Vec2(2, 0), Vec2(2, 2)}, c);
    EXPECT_TRUE(g.command(Pose2{1.68, 0.0, 0.0}, speed_now, &v, &w));
    EXPECT_EQ(g.target_index(), 0u) << "at " << speed_now << " m/s";
  }
}

}  // namespace
}  // namespace cairn::firmware
