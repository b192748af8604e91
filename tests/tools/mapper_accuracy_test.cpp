// The central mapper's accuracy against ground truth (issue 14, "Done when": >= 97 % of
// known cells agree, walls within one cell). Scans come from the HIL measurement model
// (hil/lms2xx/scan_synth: exact ray casts, 5 mm Gaussian range noise, the LMS2xx at 180°
// / 0.5°) at known poses along the world's scripted tours (robots 1-3), one scan every
// 6.7 cm of travel (0.5 m/s, every 10th scan of 75 Hz) and every 0.13 rad of turning;
// they are inserted at the true poses with the mapper's default parameters (chosen from
// the seed and first principles, docs/mapper.md; not tuned on this data).
//
// Figures: CAIRN_MAPPER_FIGURES=DIR writes DIR/<world>.pgm/.yaml/.png and the quality JSON.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>

#include "basestation/mapper/export.hpp"
#include "basestation/mapper/mapper.hpp"
#include "hil/lms2xx/scan_synth.hpp"
#include "tools/map_quality/map_quality.hpp"

namespace cairn::tools {
namespace {

constexpr double kStep = 0.5 / 7.5;  // m between inserted scans
constexpr double kTurnStep = 0.133;  // rad between inserted scans when turning in place
const Pose2 kMount{0.15, 0.0, 0.0};  // laser in the robot frame

// Robot poses along start -> waypoints: straight legs, turning in place at the corners.
std::vector<Pose2> tour(const Pose2& start, const std::vector<Vec2>& waypoints) {
  std::vector<Pose2> out{start};
  Pose2 p = start;
  for (const Vec2& w : waypoints) {
    const Vec2 d = w - p.translation();
    if (d.norm() < 1e-6) continue;
    const double heading = std::atan2(d.y(), d.x());
    const double turn = normalize_angle(heading - p.theta);
    const int nt = static_cast<int>(std::ceil(std::abs(turn) / kTurnStep));
    for (int k = 1; k <= nt; ++k) out.push_back({p.x, p.y, normalize_angle(p.theta + turn * k / nt)});
    p.theta = heading;
    const int ns = static_cast<int>(std::ceil(d.norm() / kStep));
    const Vec2 a = p.translation();
    for (int k = 1; k <= ns; ++k) {
      const Vec2 q = a + d * (static_cast<double>(k) / ns);
      out.push_back({q.x(), q.y(), heading});
    }
    p = out.back();
  }
  return out;
}

struct MapRun {
  mapper::ClassGrid map;
  MapQuality quality;
  std::size_t scans = 0;
};

MapRun map_world(const std::string& world_file, const std::vector<std::pair<int, std::vector<Vec2>>>& tours) {
  const hil::World world = hil::World::load(std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/" + world_file);
  const auto& b = world.bounds();
  mapper::MapperConfig cfg;  // defaults, bounds from the world plus a margin
  cfg.origin_x = b.xmin - 1.0;
  cfg.origin_y = b.ymin - 1.0;
  cfg.width_m = b.xmax - b.xmin + 2.0;
  cfg.height_m = b.ymax - b.ymin + 2.0;
  mapper::Mapper m(cfg);
  std::mt19937_64 rng(14);
  std::vector<hil::BeamSample> beams(static_cast<std::size_t>(hil::sweep_beams(180, 50)));
  MapRun run;
  std::vector<mapper::Trajectory> trajectories;
  for (const auto& [id, waypoints] : tours) {
    const auto start = world.start(id);
    EXPECT_TRUE(start.has_value());
    mapper::Trajectory traj{static_cast<std::uint16_t>(id), {}};
    std::uint32_t seq = 0;
    for (const Pose2& robot : tour(*start, waypoints)) {
      const Pose2 sensor = compose(robot, kMount);
      hil::synthesize_sweep(world, sensor, 180, 50, 30.0, 0.005, rng, beams.data());
      msg::LaserScan s;
      s.robot_id = static_cast<std::uint16_t>(id);
      s.seq = ++seq;
      s.angle_min = static_cast<float>(-std::numbers::pi / 2);
      s.angle_increment = static_cast<float>(0.5 * std::numbers::pi / 180);
      s.n_beams = static_cast<std::uint16_t>(beams.size());
      for (std::size_t k = 0; k < beams.size(); ++k)
        s.ranges_mm[k] = static_cast<std::uint16_t>(beams[k].hit ? std::lround(std::max(0.0, beams[k].range_m) * 1000) : 0);
      s.pose = sensor;
      s.sensor_offset = kMount;
      EXPECT_EQ(m.add_scan(s, sensor), mapper::Mapper::AddResult::kInserted);
      traj.points.push_back(robot.translation());
      ++run.scans;
    }
    trajectories.push_back(std::move(traj));
  }
  EXPECT_EQ(m.counters().scans_invalid + m.counters().scans_outside, 0u);
  run.map = m.classified();
  run.quality = evaluate(run.map, world, default_start(world));
  std::printf("%s: %zu scans\n%s", world_file.c_str(), run.scans, to_text(run.quality).c_str());
  if (const char* dir = std::getenv("CAIRN_MAPPER_FIGURES")) {
    std::filesystem::create_directories(dir);
    const std::string stem = std::string(dir) + "/" + world_file.substr(0, world_file.find('.'));
    mapper::write_map_server(run.map, stem);
    std::vector<msg::Landmark> poles;
    std::uint32_t pid = 0;
    for (const Vec2& p : world.poles()) poles.push_back({++pid, p.x(), p.y(), {0.0025, 0.0, 0.0, 0.0025}});
    mapper::write_png(run.map, trajectories, poles, stem + ".png");
    std::ofstream(stem + "_quality.json") << to_json(run.quality) << "\n";
  }
  return run;
}

void expect_bar(const MapQuality& q) {
  EXPECT_GE(q.agreement, 0.97);                       // issue 14: >= 97 % of known cells agree
  EXPECT_LE(q.wall_offset_max_m, q.resolution + 1e-9);  // walls within one cell
  EXPECT_GT(q.coverage, 0.5);                          // and the map is not trivially small
}

// The development check (run before the office figure was looked at): one robot around
// both corridors of environment B on a hand-written tour.
TEST(MapperAccuracy, TwoCorridorsOneTour) {
  const MapRun run = map_world("two_corridors.world", {{1, {{1.5, 18.5}, {23.5, 18.5}, {23.5, 1.5}, {1.5, 1.5}, {1.5, 8.75},
                                                           {23.5, 8.75}, {23.5, 11.25}, {1.5, 11.25}}}});
  expect_bar(run.quality);
}

TEST(MapperAccuracy, OfficeThreeScriptedTours) {
  const hil::World world = hil::World::load(std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world");
  const MapRun run = map_world("office.world", {{1, world.route(1)}, {2, world.route(2)}, {3, world.route(3)}});
  expect_bar(run.quality);
}

}  // namespace
}  // namespace cairn::tools
