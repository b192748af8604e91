// The central mapper on synthetic scans: the inverse sensor model, subsampling, the
// bounded store, re-rendering, and data that must never crash it.
#include "basestation/mapper/mapper.hpp"

#include <gtest/gtest.h>

#include "common/config.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace cairn::mapper {
namespace {

MapperConfig small_config() {
  MapperConfig c;
  c.resolution_m = 0.1;
  c.origin_x = -5;
  c.origin_y = -5;
  c.width_m = 10;
  c.height_m = 10;
  c.max_range_m = 4.0;
  return c;
}

msg::LaserScan make_scan(std::uint16_t robot, const std::vector<double>& ranges_m, double angle_min, double inc) {
  msg::LaserScan s;
  s.robot_id = robot;
  s.angle_min = static_cast<float>(angle_min);
  s.angle_increment = static_cast<float>(inc);
  s.n_beams = static_cast<std::uint16_t>(ranges_m.size());
  for (std::size_t k = 0; k < ranges_m.size(); ++k) s.ranges_mm[k] = static_cast<std::uint16_t>(std::lround(ranges_m[k] * 1000));
  return s;
}

Cell cell_at(const Mapper& m, double x, double y) {
  int i = 0, j = 0;
  EXPECT_TRUE(m.geometry().cell_of(x, y, &i, &j));
  return m.classify(i, j);
}

TEST(Mapper, OneBeamFreeAlongHitAtEndUnknownBeyond) {
  Mapper m(small_config());
  const auto scan = make_scan(1, {2.0}, 0.0, 0.0);
  const Pose2 pose{0.05, 0.05, 0.0};  // a cell centre
  ASSERT_EQ(m.add_scan(scan, pose), Mapper::AddResult::kInserted);
  // One hit: p = 0.7 >= p_o. One miss: p = 0.4, not yet clear (p_c = 0.196).
  EXPECT_EQ(cell_at(m, 2.05, 0.05), Cell::kObstacle);
  EXPECT_EQ(cell_at(m, 1.05, 0.05), Cell::kUnknown);
  EXPECT_NEAR(m.probability(60, 50), 0.4, 1e-3);
  for (int k = 0; k < 3; ++k) m.add_scan(scan, pose);
  // Four misses: logit 4·(-0.405) -> p = 0.165 <= p_c.
  for (double x = 0.05; x < 1.95; x += 0.1) EXPECT_EQ(cell_at(m, x, 0.05), Cell::kClear) << x;
  EXPECT_EQ(cell_at(m, 2.05, 0.05), Cell::kObstacle);
  EXPECT_EQ(cell_at(m, 2.15, 0.05), Cell::kUnknown);
  EXPECT_FALSE(m.observed(72, 50));
  EXPECT_EQ(cell_at(m, 0.05, 0.15), Cell::kUnknown);  // a neighbouring row is untouched
}

TEST(Mapper, MaxRangeAndNoReturnBeamsClearOnly) {
  Mapper m(small_config());
  // Beam 0: no return (0); beam 1 (pointing +y): beyond max_range (4.5 m > 4 m).
  const auto scan = make_scan(1, {0.0, 4.5}, 0.0, std::numbers::pi / 2);
  for (int k = 0; k < 4; ++k) m.add_scan(scan, {0.05, 0.05, 0.0});
  EXPECT_EQ(cell_at(m, 3.95, 0.05), Cell::kClear);
  EXPECT_EQ(cell_at(m, 4.15, 0.05), Cell::kUnknown);
  EXPECT_EQ(cell_at(m, 0.05, 3.95), Cell::kClear);
  EXPECT_EQ(cell_at(m, 0.05, 4.15), Cell::kUnknown);
  const ClassGrid g = m.classified();
  for (Cell c : g.cells) EXPECT_NE(c, Cell::kObstacle);
  EXPECT_EQ(m.counters().beams_max_range, 8u);
}

TEST(Mapper, EachCellUpdatedAtMostOncePerScanAndHitWins) {
  Mapper m(small_config());
  // 361 beams over 180°, all 1 m: every beam crosses the sensor's own cell.
  std::vector<double> r(361, 1.0);
  m.add_scan(make_scan(1, r, -std::numbers::pi / 2, std::numbers::pi / 360), {0.05, 0.05, 0});
  EXPECT_NEAR(m.log_odds(50, 50), logit(0.4), 1e-3);
  // Hit wins: beam 0 ends in the cell beam 1 crosses.
  Mapper h(small_config());
  h.add_scan(make_scan(1, {1.0, 2.0}, 0.0, 0.0), {0.05, 0.05, 0});
  int i = 0, j = 0;
  ASSERT_TRUE(h.geometry().cell_of(1.05, 0.05, &i, &j));
  EXPECT_NEAR(h.log_odds(i, j), logit(0.7), 1e-3);
}

TEST(Mapper, NonFiniteInputIsCountedNeverCrashes) {
  Mapper m(small_config());
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const auto scan = make_scan(1, {2.0, 1.0}, 0.0, 0.1);
  EXPECT_EQ(m.add_scan(scan, {nan, 0, 0}), Mapper::AddResult::kRejected);
  EXPECT_EQ(m.add_scan(scan, {0, inf, 0}), Mapper::AddResult::kRejected);
  EXPECT_EQ(m.add_scan(scan, {0, 0, nan}), Mapper::AddResult::kRejected);
  auto bad_angle = scan;
  bad_angle.angle_min = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(m.add_scan(bad_angle, {0, 0, 0}), Mapper::AddResult::kRejected);
  auto bad_inc = scan;
  bad_inc.angle_increment = std::numeric_limits<float>::infinity();
  EXPECT_EQ(m.add_scan(bad_inc, {0, 0, 0}), Mapper::AddResult::kRejected);
  auto too_many = scan;
  too_many.n_beams = static_cast<std::uint16_t>(msg::kMaxBeams + 1);
  EXPECT_EQ(m.add_scan(too_many, {0, 0, 0}), Mapper::AddResult::kRejected);
  EXPECT_EQ(m.counters().scans_invalid, 6u);
  // A sensor outside the grid: rejected and counted.
  EXPECT_EQ(m.add_scan(scan, {50, 0, 0}), Mapper::AddResult::kRejected);
  EXPECT_EQ(m.counters().scans_outside, 1u);
  EXPECT_EQ(m.counters().scans_inserted, 0u);
  for (Cell c : m.classified().cells) EXPECT_EQ(c, Cell::kUnknown);
  // A correction giving NaN leaves the scan where it was.
  ASSERT_EQ(m.add_scan(scan, {0.05, 0.05, 0}), Mapper::AddResult::kInserted);
  const auto st = m.rerender(1, [&](const ScanInfo&) { return std::optional<Pose2>(Pose2{nan, 0, 0}); });
  EXPECT_EQ(st.moved, 0u);
  EXPECT_EQ(m.counters().rerender_invalid_pose, 1u);
  EXPECT_EQ(cell_at(m, 2.05, 0.05), Cell::kObstacle);
}

TEST(Mapper, BeamsLeavingTheGridAreClippedAndCounted) {
  MapperConfig c = small_config();
  c.max_range_m = 30;
  Mapper m(c);
  // From near the right border, beams of 8 m in every direction: most leave the grid.
  std::vector<double> r(73, 8.0);
  ASSERT_EQ(m.add_scan(make_scan(1, r, -std::numbers::pi, 2 * std::numbers::pi / 72), {4.9, 4.9, 0.3}),
            Mapper::AddResult::kInserted);
  EXPECT_EQ(m.counters().beams_clipped, 1u);  // counted per scan with clipped beams
  EXPECT_EQ(cell_at(m, 4.95, 4.95), Cell::kUnknown);  // observed, one miss only
  EXPECT_TRUE(m.observed(99, 99));
}

TEST(Mapper, InsertsEveryNthScanPerRobot) {
  MapperConfig c = small_config();
  c.insert_every = 3;
  Mapper m(c);
  const auto a = make_scan(1, {2.0}, 0.0, 0.0), b = make_scan(2, {2.0}, 0.0, 0.0);
  int inserted_a = 0, inserted_b = 0;
  for (int k = 0; k < 9; ++k) {
    inserted_a += m.add_scan(a, {0.05, 0.05, 0}) == Mapper::AddResult::kInserted;
    if (k % 2 == 0) inserted_b += m.add_scan(b, {0.05, 1.05, 0}) == Mapper::AddResult::kInserted;
  }
  EXPECT_EQ(inserted_a, 3);  // scans 0, 3, 6
  EXPECT_EQ(inserted_b, 2);  // robot 2's 5 scans: its own count, 0 and 3
  EXPECT_EQ(m.counters().scans_subsampled, 9u);
}

// Whatever a sequence of corrections did, the grid equals one built directly at the final poses.
void expect_same_grid(const Mapper& a, const Mapper& b) {
  const GridGeometry& g = a.geometry();
  int diff = 0;
  for (int j = 0; j < g.height; ++j)
    for (int i = 0; i < g.width; ++i) diff += a.log_odds(i, j) != b.log_odds(i, j) || a.observed(i, j) != b.observed(i, j);
  EXPECT_EQ(diff, 0);
}

std::vector<msg::LaserScan> room_scans(std::uint16_t robot, int n) {
  // A 180° scan of a room, ranges varied per scan.
  std::vector<msg::LaserScan> out;
  for (int k = 0; k < n; ++k) {
    std::vector<double> r(181);
    for (std::size_t b = 0; b < r.size(); ++b) r[b] = 1.0 + 0.01 * static_cast<double>((b * 7 + static_cast<std::size_t>(k) * 3) % 150);
    auto s = make_scan(robot, r, -std::numbers::pi / 2, std::numbers::pi / 180);
    s.seq = static_cast<std::uint32_t>(k);
    s.stamp = k * kNanosPerSecond;
    s.pose = {0.1 * k, 0.0, 0.0};  // local frame
    out.push_back(s);
  }
  return out;
}

TEST(Mapper, RerenderingIsExactAndOnlyMovesScansBeyondTheThreshold) {
  const auto scans = room_scans(1, 6);
  const Pose2 wrong{0.5, -0.3, 0.2}, right{0.0, 0.2, -0.1};
  Mapper m(small_config()), direct(small_config());
  for (const auto& s : scans) {
    m.add_scan_local(s, wrong);
    direct.add_scan_local(s, right);
  }
  const RerenderStats st = m.on_frame_corrected(1, right);
  EXPECT_EQ(st.examined, 6u);
  EXPECT_EQ(st.moved, 6u);
  expect_same_grid(m, direct);
  // Another robot's scans are not touched; a move below the threshold is not re-rendered.
  EXPECT_EQ(m.on_frame_corrected(2, wrong).examined, 0u);
  const Pose2 tiny{right.x + 0.01, right.y, right.theta + 0.001};  // 0.01 + 0.001·4 = 0.014 m < 0.075 m
  EXPECT_EQ(m.on_frame_corrected(1, tiny).moved, 0u);
  expect_same_grid(m, direct);
  // on_trajectory_corrected: robot pose at the scan's time, sensor offset applied.
  const RerenderStats back = m.on_trajectory_corrected(1, [&](Nanos t) -> std::optional<Pose2> {
    return compose(wrong, scans[static_cast<std::size_t>(t / kNanosPerSecond)].pose);
  });
  EXPECT_EQ(back.moved, 6u);
  Mapper again(small_config());
  for (const auto& s : scans) again.add_scan_local(s, wrong);
  expect_same_grid(m, again);
}

// A fan of beams from the origin: a wall 3 m ahead, and another robot (a 0.3 m disc)
// standing at (1.5, 0) between, hiding part of the wall.
msg::LaserScan scan_with_robot_ahead() {
  std::vector<double> r;
  const double a0 = -0.6, inc = 0.01;
  const Vec2 c(1.5, 0.0);
  for (double a = a0; a <= 0.6 + 1e-9; a += inc) {
    const Vec2 d(std::cos(a), std::sin(a));
    double range = 3.0 / d.x();  // the wall x = 3
    const double along = d.dot(c), off2 = c.squaredNorm() - along * along;
    if (off2 < 0.09) range = std::min(range, along - std::sqrt(0.09 - off2));
    r.push_back(range);
  }
  return make_scan(1, r, a0, inc);
}

// Robots see each other in a shared building: another robot's body is not a wall. The
// returns on it clear the cells before it and leave no obstacle, also after a re-render;
// the wall around it is drawn as before. With the mask off the robot is drawn (the test
// can fail).
TEST(Mapper, ReturnsOnAnotherRobotsBodyAreNotDrawnAsObstacles) {
  const msg::LaserScan scan = scan_with_robot_ahead();
  const Pose2 at{0.05, 0.05, 0.0};
  const std::vector<Vec2> robots{Vec2(1.6, 0.1)};  // its estimate, 5 cm off in x and y (the body is at (1.55, 0.05))
  MapperConfig off = small_config();
  off.robot_mask_radius_m = 0;
  Mapper masked(small_config()), drawn(off);
  for (int k = 0; k < 4; ++k) {
    masked.add_scan(scan, at, robots);
    drawn.add_scan(scan, at, robots);
  }
  EXPECT_EQ(cell_at(drawn, 1.25, 0.05), Cell::kObstacle);  // the body's near surface
  EXPECT_NE(cell_at(masked, 1.25, 0.05), Cell::kObstacle);
  EXPECT_EQ(cell_at(masked, 0.95, 0.05), Cell::kClear);  // the beam still clears before the body
  EXPECT_EQ(cell_at(masked, 3.05, 1.05), Cell::kObstacle);  // the wall beside it
  EXPECT_GT(masked.counters().beams_on_robots, 0u);
  EXPECT_EQ(drawn.counters().beams_on_robots, 0u);
  // Moved by a correction, the scan keeps its mask.
  const Pose2 shifted{0.3, 0.0, 0.0};
  masked.on_frame_corrected(1, shifted);
  int obstacles_near_body = 0;
  for (double x = 1.35; x < 2.0; x += 0.1) {
    for (double y = -0.35; y < 0.4; y += 0.1) obstacles_near_body += cell_at(masked, x, y) == Cell::kObstacle;
  }
  EXPECT_EQ(obstacles_near_body, 0);
  // Exactly what inserting it there would have drawn (the old contribution removed bit for bit).
  Mapper fresh(small_config());
  const std::vector<Vec2> moved{Vec2(1.6 + 0.25, 0.1 - 0.05)};  // the robot moved with the frame
  for (int k = 0; k < 4; ++k) fresh.add_scan(scan, shifted, moved);
  expect_same_grid(masked, fresh);
  // Non-finite robot centres are ignored, never crash.
  Mapper nan_robot(small_config());
  const std::vector<Vec2> bad{Vec2(std::numeric_limits<double>::quiet_NaN(), 0.0)};
  EXPECT_EQ(nan_robot.add_scan(scan, at, bad), Mapper::AddResult::kInserted);
  EXPECT_EQ(nan_robot.counters().beams_on_robots, 0u);
}

TEST(Mapper, FullStoreDropsOldestScansWhichStayFrozenInTheGrid) {
  const auto scans = room_scans(1, 5);
  MapperConfig c = small_config();
  // Room for two scans of 181 beams.
  c.store_bytes = 2 * (sizeof(ScanInfo) + 256 + 181 * sizeof(std::uint16_t));
  Mapper m(c);
  const Pose2 wrong{0.5, -0.3, 0.2}, right{0.0, 0.2, -0.1};
  for (const auto& s : scans) m.add_scan_local(s, wrong);
  EXPECT_EQ(m.stored_scans(), 2u);
  EXPECT_EQ(m.counters().store_dropped, 3u);
  EXPECT_LE(m.stored_bytes(), c.store_bytes);
  EXPECT_EQ(m.on_frame_corrected(1, right).moved, 2u);
  // Expected: the three dropped scans at the old pose, the two stored ones at the new.
  Mapper expect(small_config());
  for (std::size_t k = 0; k < scans.size(); ++k) expect.add_scan_local(scans[k], k < 3 ? wrong : right);
  expect_same_grid(m, expect);
  EXPECT_EQ(m.trajectory(1).size(), 2u);
  // A zero-byte store keeps nothing: every scan is frozen at once.
  c.store_bytes = 0;
  Mapper none(c);
  none.add_scan_local(scans[0], wrong);
  EXPECT_EQ(none.counters().scans_not_stored, 1u);
  EXPECT_EQ(none.on_frame_corrected(1, right).examined, 0u);
}

TEST(Mapper, CorrectionMovingTheSensorOutsideRemovesTheScan) {
  const auto scans = room_scans(1, 2);
  Mapper m(small_config()), empty(small_config());
  for (const auto& s : scans) m.add_scan_local(s, {});
  const RerenderStats st = m.on_frame_corrected(1, {40, 0, 0});
  EXPECT_EQ(st.removed, 2u);
  EXPECT_EQ(m.stored_scans(), 0u);
  EXPECT_EQ(m.stored_bytes(), 0u);
  expect_same_grid(m, empty);
}

TEST(Mapper, ChangedRegionCoversUpdatedCells) {
  Mapper m(small_config());
  EXPECT_FALSE(m.take_changed());
  m.add_scan(make_scan(1, {2.0}, 0.0, 0.0), {0.05, 0.05, 0});
  const auto r = m.take_changed();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->i0, 50);
  EXPECT_EQ(r->i1, 70);
  EXPECT_EQ(r->j0, 50);
  EXPECT_EQ(r->j1, 50);
  EXPECT_FALSE(m.take_changed());
}

TEST(Mapper, InvalidConfigurationIsRefusedWithTheParameterNamed) {
  MapperConfig c = small_config();
  c.p_c = 0.7;
  try {
    Mapper m(c);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("p_c"), std::string::npos);
  }
  c = small_config();
  c.width_m = 1e5;
  try {
    Mapper m(c);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_cells"), std::string::npos);
  }
  c = small_config();
  c.resolution_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(Mapper{c}, std::invalid_argument);
}

TEST(MapperConfig, ReadsTheMapperSectionStrictly) {
  const auto doc = ConfigDocument::parse(
      "[mapper]\nresolution_m = 0.1\norigin = [-5.0, -2.0]\nsize_m = [20.0, 10.0]\np_o = 0.7\np_c = 0.2\n"
      "insert_every = 3\nstore_mib = 1.5\nrerender_shift_m = 0.05\nmax_range_m = 8.0\nrobot_mask_radius_m = 0.5\n",
      "test.toml");
  const MapperConfig c = mapper_config_from(doc.root().section("mapper"));
  doc.finish();
  EXPECT_DOUBLE_EQ(c.resolution_m, 0.1);
  EXPECT_DOUBLE_EQ(c.origin_x, -5.0);
  EXPECT_DOUBLE_EQ(c.height_m, 10.0);
  EXPECT_DOUBLE_EQ(c.p_o, 0.7);
  EXPECT_EQ(c.insert_every, 3);
  EXPECT_DOUBLE_EQ(c.robot_mask_radius_m, 0.5);
  EXPECT_EQ(c.store_bytes, static_cast<std::size_t>(1.5 * (1 << 20)));
  const Mapper m(c);
  EXPECT_EQ(m.geometry().width, 200);
  EXPECT_EQ(m.geometry().height, 100);
  // p_c above p_o: refused, naming the parameters.
  const auto bad = ConfigDocument::parse("[mapper]\np_o = 0.3\np_c = 0.4\n", "bad.toml");
  EXPECT_THROW(mapper_config_from(bad.root().section("mapper")), ConfigError);
  // A misspelled key is an error at finish().
  const auto typo = ConfigDocument::parse("[mapper]\nresolution = 0.1\n", "typo.toml");
  mapper_config_from(typo.root().section("mapper"));
  EXPECT_THROW(typo.finish(), ConfigError);
}

// The trajectory the map was built from, as the base exports it: the robot's body pose at
// each stored scan (the sensor pose ⊕ the inverse of the laser's mount), in time order.
TEST(Mapper, BodyTrajectoryUndoesTheLaserMountAndIsInTimeOrder) {
  Mapper m(small_config());
  msg::LaserScan a = make_scan(1, {1.0}, 0.0, 0.0);
  a.sensor_offset = {0.2, 0.0, 0.0};
  a.stamp = 2'000'000'000;
  msg::LaserScan b = a;
  b.stamp = 1'000'000'000;  // older, stored after
  ASSERT_EQ(m.add_scan(a, {0.0, 1.2, std::numbers::pi / 2}), Mapper::AddResult::kInserted);
  ASSERT_EQ(m.add_scan(b, {1.2, 0.0, 0.0}), Mapper::AddResult::kInserted);
  ASSERT_EQ(m.add_scan(make_scan(2, {1.0}, 0.0, 0.0), {0.0, 0.0, 0.0}), Mapper::AddResult::kInserted);
  const std::vector<TimedPose> t = m.body_trajectory(1);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].stamp, 1'000'000'000);
  EXPECT_NEAR(t[0].pose.x, 1.0, 1e-12);
  EXPECT_NEAR(t[0].pose.y, 0.0, 1e-12);
  EXPECT_EQ(t[1].stamp, 2'000'000'000);
  EXPECT_NEAR(t[1].pose.x, 0.0, 1e-12);
  EXPECT_NEAR(t[1].pose.y, 1.0, 1e-12);
  EXPECT_NEAR(t[1].pose.theta, std::numbers::pi / 2, 1e-12);
  EXPECT_EQ(m.body_trajectory(2).size(), 1u);
  EXPECT_TRUE(m.body_trajectory(3).empty());
}

}  // namespace
}  // namespace cairn::mapper
