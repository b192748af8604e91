// The pure-pursuit follower: it drives a unicycle to the end of a path, and a looped path
// whose waypoints all lie within reach holds the robot still instead of spinning for ever.
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
  for (; steps < 5000 && f.command(pose, &v, &w); ++steps) pose = compose(pose, arc_motion(v, w, 0.02));
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
  EXPECT_TRUE(one.command(Pose2{}, &v, &w));
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(w, 0.0);
  PathFollower three({Vec2(0.05, 0), Vec2(0, 0.05), Vec2(-0.05, 0)}, c);
  EXPECT_TRUE(three.command(Pose2{}, &v, &w));
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(w, 0.0);
  // Out of reach again, it drives on.
  EXPECT_TRUE(three.command(Pose2{-2, 0, 0}, &v, &w));
  EXPECT_NE(v + w, 0.0);
}

}  // namespace
}  // namespace cairn::firmware
