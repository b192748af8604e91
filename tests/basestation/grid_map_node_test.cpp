// The base's central mapper on DDS: LaserScans read from the topic are placed by the
// fusion's estimate (a robot it has not localised is counted, not mapped); only tiles that
// changed are published; a reader that joins late receives every tile of the map, cell for
// cell, and so does a robot's own copy (firmware/global_map.hpp); the export is what
// map_server reads back, and a failed export is reported, not thrown.
#include "basestation/grid_map_node.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>

#include "basestation/mapper/export.hpp"
#include "common/dds/convert.hpp"
#include "firmware/robot_bridge.hpp"

namespace cairn::base {
namespace {

constexpr std::uint32_t kDomain = 112;  // this test's own domain
const Pose2 kStart{1.0, 2.0, 0.3};      // robot 1's known start: the map frame

BaseConfig small_config() {
  BaseConfig c;
  c.dds = dds::loopback_profile(kDomain);
  RobotPrior p;
  p.known = true;
  p.pose = kStart;
  p.sigma = Vec3(0.05, 0.05, 0.01);
  c.fusion.robots[1] = p;
  c.mapper.origin_x = c.mapper.origin_y = -12.0;
  c.mapper.width_m = c.mapper.height_m = 48.0;  // 320 x 320 cells: 5 x 5 tiles of 64
  c.mapper.max_range_m = 8.0;
  c.map_tile_period = 0;  // every poll
  c.map_reframe_period = kNanosPerSecond;
  return c;
}

// Robot 1 at the origin of its local frame, in a 10 m square room centred on it (local
// frame), 360 beams.
msg::LaserScan room_scan(std::uint16_t robot, std::uint32_t seq) {
  msg::LaserScan s;
  s.robot_id = robot;
  s.seq = seq;
  s.stamp = seq * 100 * kNanosPerMilli;
  s.n_beams = 360;
  s.angle_min = static_cast<float>(-std::numbers::pi);
  s.angle_increment = static_cast<float>(std::numbers::pi / 180);
  for (std::size_t b = 0; b < s.n_beams; ++b) {
    const double a = -std::numbers::pi + static_cast<double>(b) * std::numbers::pi / 180;
    const double r = 5.0 / std::max(std::abs(std::cos(a)), std::abs(std::sin(a)));
    s.ranges_mm[b] = static_cast<std::uint16_t>(std::lround(r * 1000));
  }
  return s;
}

void localise(Fusion* f) {
  msg::OdometryIncrement o;
  o.robot_id = 1;
  o.seq = 1;
  o.t0 = 0;
  o.t1 = 10 * kNanosPerMilli;
  o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
  o.boot_epoch = 7;
  ASSERT_EQ(f->on_odometry(o), Fusion::Result::kApplied);
  msg::PoseCorrection c;
  ASSERT_TRUE(f->correction(1, 0, &c));
}

// Polls until `done()` or 5 s of wall time (DDS delivery on loopback).
template <typename F>
bool poll_until(GridMapNode& node, const Fusion& fusion, F done) {
  auto& clock = MonotonicClock::instance();
  const Nanos end = clock.now() + 5 * kNanosPerSecond;
  while (clock.now() < end) {
    node.poll(clock.now(), fusion);
    if (done()) return true;
    usleep(5000);
  }
  return false;
}

TEST(GridMapNode, ScansFromDdsBuildTheMapOnlyChangedTilesGoOutAndALateReaderGetsThemAll) {
  const BaseConfig cfg = small_config();
  dds::Participant pp(cfg.dds);
  Fusion fusion(cfg.fusion);
  localise(&fusion);
  GridMapNode node(pp, cfg);
  ASSERT_EQ(node.tiles_x(), 5);
  ASSERT_EQ(node.tiles_y(), 5);

  dds::Topic<cairn_LaserScan> scan_topic(pp);
  dds::RobotWriters<cairn_LaserScan> scan_writer(pp, scan_topic, dds::state_qos(16), {1, 9});  // each in its partition
  ASSERT_TRUE(scan_writer.wait_for_readers(1, 5 * kNanosPerSecond));
  auto sample = std::make_unique<cairn_LaserScan>();
  dds::to_dds(room_scan(9, 1), sample.get());  // robot 9: unknown to the fusion
  ASSERT_TRUE(scan_writer.write(*sample));
  for (std::uint32_t k = 1; k <= 5; ++k) {
    dds::to_dds(room_scan(1, k), sample.get());
    ASSERT_TRUE(scan_writer.write(*sample));
  }
  ASSERT_TRUE(poll_until(node, fusion, [&] { return node.counters().scans_taken == 6; })) << node.summary();
  EXPECT_EQ(node.counters().scans_unplaced, 1u);
  EXPECT_EQ(node.mapper().counters().scans_inserted, 5u);
  // The mapped area the base reports when exploration ends, against the classified map.
  {
    const ClassGrid now = node.mapper().classified();
    const double cell_m2 = now.geometry.resolution * now.geometry.resolution;
    const auto count = [&](Cell c) { return static_cast<double>(std::count(now.cells.begin(), now.cells.end(), c)); };
    const GridMapNode::Area area = node.area();
    EXPECT_GT(count(Cell::kClear), 100.0);
    EXPECT_GT(count(Cell::kObstacle), 10.0);
    EXPECT_NEAR(area.clear_m2, count(Cell::kClear) * cell_m2, 1e-9);
    EXPECT_NEAR(area.obstacle_m2, count(Cell::kObstacle) * cell_m2, 1e-9);
    // And against the room itself: 10 x 10 m seen from inside, its 40 m of wall about a
    // cell thick.
    std::printf("room: %.1f m2 clear, %.1f m2 obstacle\n", area.clear_m2, area.obstacle_m2);
    EXPECT_GT(area.clear_m2, 70.0);
    EXPECT_LT(area.clear_m2, 100.0);
    EXPECT_GT(area.obstacle_m2, 40 * now.geometry.resolution * 0.5);
    EXPECT_LT(area.obstacle_m2, 40 * now.geometry.resolution * 3);
  }

  // The room's corners are 7.07 m from the robot at (1, 2): it spans at most global
  // [-6.1, 8.1] x [-5.1, 9.1], cells 39..134 x 46..141, tiles 0..2 on each axis. The other
  // 16 of the 25 tiles are never touched: not published.
  EXPECT_EQ(node.counters().tiles_published, 9u) << node.summary();
  const std::uint64_t published = node.counters().tiles_published;
  node.poll(MonotonicClock::instance().now(), fusion);
  EXPECT_EQ(node.counters().tiles_published, published) << "nothing changed: nothing to send";

  // A robot that starts now: transient-local hands it every tile there is.
  dds::Topic<cairn_MapTile> tile_topic(pp);
  dds::Reader<cairn_MapTile> late(pp, tile_topic, dds::latched_qos(1));
  std::map<std::pair<int, int>, std::unique_ptr<cairn_MapTile>> got;
  const Nanos end = MonotonicClock::instance().now() + 5 * kNanosPerSecond;
  while (got.size() < 9 && MonotonicClock::instance().now() < end) {
    late.wait(100 * kNanosPerMilli);
    late.take([&](const cairn_MapTile& t, const dds_sample_info_t&) {
      got[{t.tile_x, t.tile_y}] = std::make_unique<cairn_MapTile>(t);
    });
  }
  ASSERT_EQ(got.size(), 9u);
  std::vector<std::uint8_t> expect(cairn_TILE_CELLS * cairn_TILE_CELLS);
  int obstacle_cells = 0;
  for (const auto& [xy, t] : got) {
    EXPECT_LE(xy.first, 2);
    EXPECT_LE(xy.second, 2);
    EXPECT_EQ(t->robot_id, 0);
    EXPECT_FLOAT_EQ(t->resolution, 0.15f);
    EXPECT_DOUBLE_EQ(t->origin_x, -12.0 + xy.first * 64 * 0.15);
    EXPECT_DOUBLE_EQ(t->origin_y, -12.0 + xy.second * 64 * 0.15);
    node.tile_cells(xy.first, xy.second, expect.data());
    int diff = 0;
    for (std::size_t c = 0; c < expect.size(); ++c) {
      diff += t->cells[c] != expect[c];
      obstacle_cells += t->cells[c] != kMapTileUnknown && t->cells[c] >= 65;
    }
    EXPECT_EQ(diff, 0) << "tile " << xy.first << "," << xy.second;
  }
  EXPECT_GT(obstacle_cells, 4 * 60) << "the room's four 10 m walls";
  // The wall ahead of the robot (5 m along its heading, in the map frame) is an obstacle.
  int i = 0, j = 0;
  ASSERT_TRUE(node.mapper().geometry().cell_of(kStart.x + 5.05 * std::cos(kStart.theta), kStart.y + 5.05 * std::sin(kStart.theta), &i, &j));
  EXPECT_EQ(node.mapper().classify(i, j), mapper::Cell::kObstacle);
  // ... and so it is in the tile a robot received, at the cell the layout puts it
  // (row-major from the tile's lower-left corner, rows along y), independently of tile_cells().
  const auto received = [&](int ci, int cj) { return got.at({ci / 64, cj / 64})->cells[(cj % 64) * 64 + ci % 64]; };
  EXPECT_GE(received(i, j), 65);
  EXPECT_NE(received(i, j), kMapTileUnknown);
  // A cell 2 m ahead of the robot, inside the room, is clear there.
  ASSERT_TRUE(node.mapper().geometry().cell_of(kStart.x + 2.0 * std::cos(kStart.theta), kStart.y + 2.0 * std::sin(kStart.theta), &i, &j));
  EXPECT_LE(received(i, j), 20);

  // The robot's own copy (firmware/global_map.hpp), started now on its own participant: it
  // holds all 9 tiles and classifies every cell as the base does, but for cells within the
  // wire's 1 % step of a threshold.
  firmware::RobotConfig rc;
  rc.id = 1;
  rc.name = "late-robot";
  rc.dds = cfg.dds;
  dds::Participant robot_pp(rc.dds);
  firmware::RobotBridge bridge(robot_pp, rc);
  const Nanos end2 = MonotonicClock::instance().now() + 5 * kNanosPerSecond;
  while (bridge.global_map().tiles() < 9 && MonotonicClock::instance().now() < end2) {
    bridge.take_map_tiles();
    usleep(5000);
  }
  ASSERT_EQ(bridge.global_map().tiles(), 9u);
  EXPECT_EQ(bridge.global_map().counters().out_of_room + bridge.global_map().counters().invalid, 0u);
  ClassGrid robot_map;
  ASSERT_TRUE(bridge.global_map().classify(&robot_map));
  ASSERT_EQ(robot_map.geometry.width, 3 * 64);
  ASSERT_EQ(robot_map.geometry.height, 3 * 64);
  EXPECT_DOUBLE_EQ(robot_map.geometry.origin_x, -12.0);
  EXPECT_DOUBLE_EQ(robot_map.geometry.origin_y, -12.0);
  int compared = 0, differ = 0, robot_obstacles = 0;
  for (int cj = 0; cj < robot_map.geometry.height; ++cj) {
    for (int ci = 0; ci < robot_map.geometry.width; ++ci) {
      const Cell mine = robot_map.at(ci, cj);
      robot_obstacles += mine == Cell::kObstacle;
      if (!node.mapper().observed(ci, cj)) {
        differ += mine != Cell::kUnknown;
        ++compared;
        continue;
      }
      const double pct = 100.0 * node.mapper().probability(ci, cj);
      if (std::abs(pct - 65.0) < 1.0 || std::abs(pct - 19.6) < 1.0) continue;
      differ += static_cast<int>(mine) != static_cast<int>(node.mapper().classify(ci, cj));
      ++compared;
    }
  }
  EXPECT_GT(compared, 192 * 192 - 200);
  EXPECT_EQ(differ, 0);
  EXPECT_GT(robot_obstacles, 4 * 60) << "the room's four 10 m walls";
}

TEST(GridMapNode, ExportIsWhatMapServerReadsAndAFailedExportIsReportedNotThrown) {
  const BaseConfig cfg = small_config();
  dds::Participant pp(cfg.dds);
  Fusion fusion(cfg.fusion);
  localise(&fusion);
  GridMapNode node(pp, cfg);
  dds::Topic<cairn_LaserScan> scan_topic(pp);
  dds::Writer<cairn_LaserScan> scan_writer(pp, scan_topic, dds::state_qos(16), 1);
  ASSERT_TRUE(scan_writer.wait_for_readers(1, 5 * kNanosPerSecond));
  auto sample = std::make_unique<cairn_LaserScan>();
  dds::to_dds(room_scan(1, 1), sample.get());
  ASSERT_TRUE(scan_writer.write(*sample));
  ASSERT_TRUE(poll_until(node, fusion, [&] { return node.counters().scans_taken == 1; }));

  const auto dir = std::filesystem::temp_directory_path() / ("cairn-grid-export-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(node.export_to((dir / "out").string(), fusion), "");
  const mapper::ClassGrid back = mapper::read_map_server((dir / "out" / "map.yaml").string());
  const mapper::ClassGrid now = node.mapper().classified();
  EXPECT_EQ(back.geometry.width, now.geometry.width);
  EXPECT_EQ(back.geometry.height, now.geometry.height);
  EXPECT_DOUBLE_EQ(back.geometry.origin_x, now.geometry.origin_x);
  EXPECT_TRUE(back.cells == now.cells);
  EXPECT_GT(std::filesystem::file_size(dir / "out" / "map.png"), 1000u);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "landmarks.json"));
  // The trajectory the map was built from: robot 1's one scan, in robot time.
  const auto poses = mapper::read_trajectories_csv((dir / "out" / "trajectories.csv").string());
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].robot, 1);
  EXPECT_EQ(poses[0].stamp, room_scan(1, 1).stamp);
  EXPECT_EQ(node.counters().exports, 1u);

  // A file where the folder should be: the export fails, says why, and nothing throws.
  std::filesystem::create_directories(dir);
  { std::FILE* f = std::fopen((dir / "blocker").c_str(), "w"); ASSERT_NE(f, nullptr); std::fclose(f); }
  const std::string error = node.export_to((dir / "blocker" / "map").string(), fusion);
  EXPECT_NE(error, "");
  EXPECT_EQ(node.counters().export_failures, 1u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn::base
