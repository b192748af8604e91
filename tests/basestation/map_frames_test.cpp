// Scans placed at the frame of their own time: mapper::FrameHistory (record, skip,
// interpolate, clock going back, restarts, capacity) and base::MapFrames with the mapper on a robot
// whose local frame drifts while it drives along a wall. Redrawing every stored scan with
// the latest frame (the rule before) bends that wall; the frames of their times keep it.
#include "basestation/map_frames.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace cairn::base {
namespace {

using mapper::FrameHistory;

constexpr Nanos kS = kNanosPerSecond;

void expect_pose(const std::optional<Pose2>& p, const Pose2& want, double tol = 1e-12) {
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->x, want.x, tol);
  EXPECT_NEAR(p->y, want.y, tol);
  EXPECT_NEAR(normalize_angle(p->theta - want.theta), 0.0, tol);
}

TEST(FrameHistory, InterpolatesBetweenFramesHoldsTheLastAndKnowsNothingBefore) {
  FrameHistory h(16);
  EXPECT_FALSE(h.at(0).has_value());
  ASSERT_TRUE(h.record(10 * kS, {1.0, 2.0, 0.1}));
  ASSERT_TRUE(h.record(20 * kS, {2.0, 0.0, 0.3}));
  EXPECT_FALSE(h.at(10 * kS - 1).has_value());
  expect_pose(h.at(10 * kS), {1.0, 2.0, 0.1});
  expect_pose(h.at(15 * kS), {1.5, 1.0, 0.2});
  expect_pose(h.at(20 * kS), {2.0, 0.0, 0.3});
  expect_pose(h.at(99 * kS), {2.0, 0.0, 0.3});
  // Across ±π the turn is the short way round.
  FrameHistory w(4);
  ASSERT_TRUE(w.record(0, {0, 0, std::numbers::pi - 0.1}));
  ASSERT_TRUE(w.record(2 * kS, {0, 0, -std::numbers::pi + 0.1}));
  expect_pose(w.at(kS), {0, 0, std::numbers::pi}, 1e-9);
}

TEST(FrameHistory, UnchangedFramesAreNotKeptSoDriftGrowsEvenlyUntilTheUpdate) {
  // The fusion's frame only moves at an update; polled every second it reads the same
  // frame until then. Keeping those would put the whole correction between 3 s and 4 s.
  FrameHistory h(16);
  for (int s = 0; s < 4; ++s) ASSERT_TRUE(h.record(s * kS, {0.0, 0.0, 0.0}));
  ASSERT_TRUE(h.record(4 * kS, {0.4, 0.0, 0.0}));
  EXPECT_EQ(h.size(), 2u);
  expect_pose(h.at(2 * kS), {0.2, 0.0, 0.0});
  // Below a millimetre and a tenth of a milliradian is "unchanged"; just above is not.
  ASSERT_TRUE(h.record(5 * kS, {0.4 + 0.9 * FrameHistory::kMinShiftM, 0.0, 0.9 * FrameHistory::kMinTurnRad}));
  EXPECT_EQ(h.size(), 2u);
  ASSERT_TRUE(h.record(6 * kS, {0.4, 0.0, 1.1 * FrameHistory::kMinTurnRad}));
  EXPECT_EQ(h.size(), 3u);
}

TEST(FrameHistory, SameTimeReplacesAnOlderTimeDropsTheLaterFramesAndNonFiniteIsRefused) {
  FrameHistory h(16);
  ASSERT_TRUE(h.record(kS, {1, 0, 0}));
  ASSERT_TRUE(h.record(2 * kS, {2, 0, 0}));
  ASSERT_TRUE(h.record(2 * kS, {3, 0, 0}));  // a second update at the same estimate time
  EXPECT_EQ(h.size(), 2u);
  expect_pose(h.at(2 * kS), {3, 0, 0});
  ASSERT_TRUE(h.record(kS / 2, {7, 0, 0}));  // the robot's clock went back: a reboot
  EXPECT_EQ(h.size(), 1u);
  expect_pose(h.at(5 * kS), {7, 0, 0});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(h.record(9 * kS, {nan, 0, 0}));
  EXPECT_FALSE(h.record(9 * kS, {0, 0, std::numeric_limits<double>::infinity()}));
  EXPECT_EQ(h.size(), 1u);
  EXPECT_THROW(FrameHistory(0), std::invalid_argument);
}

TEST(FrameHistory, ARestartBeginsANewLocalFrameThatIsNeverBlendedWithTheOld) {
  // Boot 1: frames at 0 s and 10 s. The robot restarts; boot 2's local frame begins at
  // 12 s (its first odometry) and the fusion's first frame of it is at 13 s.
  FrameHistory h(16);
  ASSERT_TRUE(h.record(0, {0, 0, 0}, 1, 0));
  ASSERT_TRUE(h.record(10 * kS, {1, 0, 0}, 1, 0));
  ASSERT_TRUE(h.record(13 * kS, {5, 5, 1}, 2, 12 * kS));
  ASSERT_TRUE(h.record(20 * kS, {6, 5, 1}, 2, 12 * kS));
  expect_pose(h.at(5 * kS), {0.5, 0, 0});
  expect_pose(h.at(11 * kS), {1, 0, 0});     // boot 1 after its last frame: held, not blended
  expect_pose(h.at(12 * kS), {5, 5, 1});     // boot 2 from its start
  expect_pose(h.at(16 * kS + kS / 2), {5.5, 5, 1});
  // A restart whose first frame equals the old one is still a new segment.
  ASSERT_TRUE(h.record(30 * kS, {6, 5, 1}, 3, 29 * kS));
  EXPECT_EQ(h.size(), 5u);
  expect_pose(h.at(25 * kS), {6, 5, 1});
  // A new segment at the old one's last instant replaces that frame.
  ASSERT_TRUE(h.record(30 * kS, {7, 7, 0}, 4, 30 * kS));
  EXPECT_EQ(h.size(), 5u);
  expect_pose(h.at(30 * kS), {7, 7, 0});
}

TEST(FrameHistory, AFullHistoryDropsItsOldestFramesAndCountsThem) {
  FrameHistory h(3);
  for (int s = 0; s < 5; ++s) ASSERT_TRUE(h.record(s * kS, {static_cast<double>(s), 0, 0}));
  EXPECT_EQ(h.size(), 3u);
  EXPECT_EQ(h.dropped(), 2u);
  EXPECT_FALSE(h.at(kS).has_value());  // older than every frame kept
  expect_pose(h.first(), {2, 0, 0});
  expect_pose(h.at(3 * kS + kS / 2), {3.5, 0, 0});
}

// A robot drives 1 m/s along x for 20 s, 3 m from a wall at y = 3 (global), one scan
// a second. Its local frame drifts: local→global C(t) = (0.02 t, -0.03 t, 0.005 t), so
// by 20 s its local frame is 0.6 m and 5.7° off. The fusion learns C only at updates,
// every 5 s, and is polled every second (reading the last update's C in between).
struct DriftingRobot {
  static Pose2 truth(double t) { return {t, 0.0, 0.0}; }
  static Pose2 frame(double t) { return {0.02 * t, -0.03 * t, 0.005 * t}; }
  static msg::LaserScan scan(int second) {
    const double t = second;
    msg::LaserScan s;
    s.robot_id = 1;
    s.seq = static_cast<std::uint32_t>(second + 1);
    s.stamp = second * kS;
    s.pose = compose(inverse(frame(t)), truth(t));  // where the robot believes its sensor is
    const double first = 25 * std::numbers::pi / 180, inc = std::numbers::pi / 180;
    s.angle_min = static_cast<float>(first);
    s.angle_increment = static_cast<float>(inc);
    s.n_beams = 131;  // 25°..155°: the wall at y = 3 within 7.1 m
    for (std::uint16_t b = 0; b < s.n_beams; ++b) {
      const double a = static_cast<double>(s.angle_min) + b * static_cast<double>(s.angle_increment);
      s.ranges_mm[b] = static_cast<std::uint16_t>(std::lround(3.0 / std::sin(a) * 1000));
    }
    return s;
  }
};

mapper::MapperConfig corridor_config() {
  mapper::MapperConfig c;
  c.resolution_m = 0.1;
  c.origin_x = -10;
  c.origin_y = -5;
  c.width_m = 40;
  c.height_m = 15;
  c.max_range_m = 8.0;
  c.rerender_shift_m = 0.005;
  return c;
}

// Obstacle cells more than a cell off the wall's row (y in [3.0, 3.1) is its cell).
int obstacles_off_the_wall(const mapper::Mapper& m) {
  int n = 0;
  for (int j = 0; j < m.geometry().height; ++j) {
    const double y = m.geometry().origin_y + (j + 0.5) * m.geometry().resolution;
    for (int i = 0; i < m.geometry().width; ++i) {
      if (m.classify(i, j) == Cell::kObstacle && std::abs(y - 3.05) > 0.11) ++n;
    }
  }
  return n;
}

TEST(MapFrames, ScansStayWhereTheRobotWasWhileItsLocalFrameDrifts) {
  mapper::Mapper map(corridor_config());
  MapFrames frames;
  double update_t = 0;
  for (int second = 0; second <= 20; ++second) {
    if (second % 5 == 0) update_t = second;
    // Polled every second: the frame of the last update, at the estimate's time.
    ASSERT_TRUE(frames.record(1, second * kS, DriftingRobot::frame(update_t)));
    ASSERT_TRUE(frames.place(map, DriftingRobot::scan(second)));
    if (second % 5 == 0) frames.rerender(map);
  }
  EXPECT_EQ(map.counters().scans_inserted, 21u);
  // Every scan is drawn where the robot was (within the re-render threshold): between
  // updates the drift the next one removed grew evenly, as it did here.
  const std::vector<mapper::TimedPose> traj = map.body_trajectory(1);
  ASSERT_EQ(traj.size(), 21u);
  double worst = 0;
  for (const mapper::TimedPose& p : traj) {
    const Pose2 want = DriftingRobot::truth(static_cast<double>(p.stamp) / kS);
    const double off = std::hypot(p.pose.x - want.x, p.pose.y - want.y) +
                       std::abs(normalize_angle(p.pose.theta - want.theta)) * corridor_config().max_range_m;
    worst = std::max(worst, off);
  }
  std::printf("worst scan placement %.4f m (threshold %.3f m)\n", worst, corridor_config().rerender_shift_m);
  EXPECT_LE(worst, corridor_config().rerender_shift_m + 1e-9);
  EXPECT_EQ(obstacles_off_the_wall(map), 0);

  // The rule before: every stored scan redrawn with the robot's latest frame. The first
  // scans land 0.6 m and 5.7° away from where they were taken and the wall bends.
  mapper::Mapper latest(corridor_config());
  for (int second = 0; second <= 20; ++second) {
    (void)latest.add_scan_local(DriftingRobot::scan(second), DriftingRobot::frame(5.0 * (second / 5)));
  }
  (void)latest.on_frame_corrected(1, DriftingRobot::frame(20));
  std::printf("obstacle cells off the wall: %d with the frames of their times, %d with the latest frame\n",
              obstacles_off_the_wall(map), obstacles_off_the_wall(latest));
  EXPECT_GT(obstacles_off_the_wall(latest), 20);
}

TEST(MapFrames, AScanOlderThanEveryFrameUsesTheFirstAndAnUnknownRobotHasNoPlace) {
  mapper::Mapper map(corridor_config());
  MapFrames frames;
  msg::LaserScan s = DriftingRobot::scan(0);
  EXPECT_FALSE(frames.place(map, s));  // no frame of robot 1 yet
  ASSERT_TRUE(frames.record(1, 10 * kS, {0.0, 1.0, 0.0}));
  s.stamp = 5 * kS;
  ASSERT_TRUE(frames.place(map, s));
  ASSERT_EQ(map.body_trajectory(1).size(), 1u);
  EXPECT_NEAR(map.body_trajectory(1)[0].pose.y, 1.0, 1e-12);
  s.robot_id = 2;
  EXPECT_FALSE(frames.place(map, s));
  // Re-rendering leaves a scan older than every frame where it is.
  ASSERT_TRUE(frames.record(1, 11 * kS, {0.0, 2.0, 0.0}));
  frames.rerender(map);
  EXPECT_NEAR(map.body_trajectory(1)[0].pose.y, 1.0, 1e-12);
}

// A fusion that knows robot 1 starts at `start` (the map frame).
FusionConfig robot_1_at(const Pose2& start) {
  FusionConfig fc;
  RobotPrior p;
  p.known = true;
  p.pose = start;
  p.sigma = Vec3(0.05, 0.05, 0.01);
  fc.robots[1] = p;
  return fc;
}

TEST(MapFrames, TheFusionsFrameIsRecordedAtItsEstimatesTimeAndOnlyLocalisedRobotsArePlaced) {
  Fusion fusion(robot_1_at({1.0, 2.0, 0.3}));
  mapper::Mapper map(corridor_config());
  MapFrames frames;
  msg::LaserScan s = DriftingRobot::scan(0);
  EXPECT_FALSE(frames.place(map, s, fusion));  // no odometry yet: not localised
  msg::OdometryIncrement o;
  o.robot_id = 1;
  o.seq = 1;
  o.t1 = 7 * kS;
  o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
  o.boot_epoch = 3;
  ASSERT_EQ(fusion.on_odometry(o), Fusion::Result::kApplied);
  Fusion::EstimateClock when;
  ASSERT_TRUE(fusion.estimate_clock(1, &when));
  EXPECT_EQ(when.t, 7 * kS);
  EXPECT_EQ(when.boot_epoch, 3u);
  EXPECT_EQ(when.boot_t0, 7 * kS);
  EXPECT_FALSE(fusion.estimate_clock(2, &when));
  s.stamp = 7 * kS;
  s.pose = {};
  ASSERT_TRUE(frames.place(map, s, fusion));
  ASSERT_EQ(map.body_trajectory(1).size(), 1u);
  const Pose2 at = map.body_trajectory(1)[0].pose;
  EXPECT_NEAR(at.x, 1.0, 1e-9);
  EXPECT_NEAR(at.y, 2.0, 1e-9);
  EXPECT_NEAR(at.theta, 0.3, 1e-9);
  s.robot_id = 2;
  EXPECT_FALSE(frames.place(map, s, fusion));
}

// Robot 1 looks along x at a wall 3 m ahead; robot 2 (a 0.3 m disc) stands 1.5 m ahead
// of it. Placed through the fusion, robot 1's returns on robot 2 are not drawn once robot
// 2 is localised; before, they are (the mask uses the fusion's estimates, not truth).
TEST(MapFrames, AnotherLocalisedRobotsBodyIsNotDrawnAsAnObstacle) {
  FusionConfig fc = robot_1_at({0.0, 0.0, 0.0});
  RobotPrior p2 = fc.robots[1];
  p2.pose = {1.5, 0.0, 0.0};
  fc.robots[2] = p2;
  Fusion fusion(fc);
  msg::LaserScan s;
  s.robot_id = 1;
  s.seq = 1;
  s.stamp = kS;
  s.angle_min = -0.5f;
  s.angle_increment = 0.01f;
  s.n_beams = 101;
  for (std::uint16_t b = 0; b < s.n_beams; ++b) {
    const double a = static_cast<double>(s.angle_min) + b * static_cast<double>(s.angle_increment);
    const Vec2 d(std::cos(a), std::sin(a)), c(1.5, 0.0);
    double r = 3.0 / d.x();
    const double along = d.dot(c), off2 = c.squaredNorm() - along * along;
    if (off2 < 0.09) r = std::min(r, along - std::sqrt(0.09 - off2));
    s.ranges_mm[b] = static_cast<std::uint16_t>(std::lround(r * 1000));
  }
  auto odometry = [&](std::uint16_t robot) {
    msg::OdometryIncrement o;
    o.robot_id = robot;
    o.seq = 1;
    o.t1 = kS;
    o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
    ASSERT_EQ(fusion.on_odometry(o), Fusion::Result::kApplied);
  };
  auto body_cell = [](const mapper::Mapper& m) {
    int i = 0, j = 0;
    EXPECT_TRUE(m.geometry().cell_of(1.25, 0.05, &i, &j));  // robot 2's near surface
    return m.classify(i, j);
  };
  odometry(1);
  mapper::Mapper alone(corridor_config()), together(corridor_config());
  MapFrames frames;
  ASSERT_TRUE(frames.place(alone, s, fusion));  // robot 2 not localised: drawn
  EXPECT_EQ(body_cell(alone), Cell::kObstacle);
  EXPECT_EQ(alone.counters().beams_on_robots, 0u);
  odometry(2);
  ASSERT_TRUE(frames.place(together, s, fusion));
  EXPECT_NE(body_cell(together), Cell::kObstacle);
  EXPECT_GT(together.counters().beams_on_robots, 0u);
}

// A robot restarts (new boot epoch, new local frame) while the base keeps its map. The
// restart may reach the fusion first through a features message, before the new boot's
// first odometry: the fusion then has no time for the new frame. The scans of the old
// boot stay where they were drawn, and the new boot's are drawn in the new frame.
TEST(MapFrames, ARobotRestartLeavesTheOldBootsScansWhereTheyWereDrawn) {
  Fusion fusion(robot_1_at({1.0, 2.0, 0.0}));
  mapper::Mapper map(corridor_config());
  MapFrames frames;
  msg::OdometryIncrement o;
  o.robot_id = 1;
  o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
  o.boot_epoch = 3;
  // Boot 3: the robot drives 4 m along its local x in 4 s.
  for (int k = 0; k <= 4; ++k) {
    o.seq = static_cast<std::uint32_t>(k + 1);
    o.t0 = (k - 1) * kS;
    o.t1 = k * kS;
    o.delta = k == 0 ? Pose2{} : Pose2{1.0, 0, 0};
    o.local_pose = {static_cast<double>(k), 0, 0};
    ASSERT_EQ(fusion.on_odometry(o), Fusion::Result::kApplied);
    frames.record(fusion);
  }
  msg::LaserScan s = DriftingRobot::scan(0);
  s.stamp = 2 * kS;
  s.pose = {2.0, 0, 0};
  ASSERT_TRUE(frames.place(map, s, fusion));
  const Pose2 drawn = map.body_trajectory(1).at(0).pose;
  EXPECT_NEAR(drawn.x, 3.0, 1e-9);
  EXPECT_NEAR(drawn.y, 2.0, 1e-9);

  // Boot 4 announces itself with a features message (no odometry yet).
  msg::FeatureObservations f;
  f.robot_id = 1;
  f.seq = 1;
  f.stamp = 6 * kS;
  f.boot_epoch = 4;
  (void)fusion.on_features(f);
  Fusion::EstimateClock when;
  ASSERT_FALSE(fusion.estimate_clock(1, &when));
  frames.record(fusion);  // nothing to record: the old frame has no new time
  msg::LaserScan early = s;
  early.stamp = 6 * kS;
  early.pose = {};
  EXPECT_FALSE(frames.place(map, early, fusion)) << "a scan of the new boot before its first odometry has no frame";
  frames.rerender(map);
  ASSERT_EQ(map.body_trajectory(1).size(), 1u);
  EXPECT_NEAR(map.body_trajectory(1)[0].pose.x, 3.0, 1e-9) << "the old boot's scan moved";

  // Boot 4's first odometry re-anchors the local frame at the robot's place (5, 2).
  o.boot_epoch = 4;
  o.seq = 1;
  o.t0 = 7 * kS;
  o.t1 = 8 * kS;
  o.delta = {};
  o.local_pose = {};
  ASSERT_EQ(fusion.on_odometry(o), Fusion::Result::kApplied);
  ASSERT_TRUE(fusion.estimate_clock(1, &when));
  EXPECT_EQ(when.boot_epoch, 4u);
  EXPECT_EQ(when.boot_t0, 8 * kS);
  frames.record(fusion);
  msg::LaserScan late = s;
  late.stamp = 9 * kS;
  late.pose = {};
  ASSERT_TRUE(frames.place(map, late, fusion));
  frames.rerender(map);
  const std::vector<mapper::TimedPose> t = map.body_trajectory(1);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_NEAR(t[0].pose.x, 3.0, 1e-9) << "the old boot's scan was redrawn in the new frame";
  EXPECT_NEAR(t[1].pose.x, 5.0, 0.05);
  EXPECT_NEAR(t[1].pose.y, 2.0, 0.05);
}

}  // namespace
}  // namespace cairn::base
