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
#include <map>
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

struct Scans {
  std::vector<msg::LaserScan> scans;  // pose = the true global sensor pose
  std::vector<mapper::Trajectory> trajectories;
};

Scans synthesize(const hil::World& world, const std::vector<std::pair<int, std::vector<Vec2>>>& tours) {
  std::mt19937_64 rng(14);
  std::vector<hil::BeamSample> beams(static_cast<std::size_t>(hil::sweep_beams(180, 50)));
  Scans out;
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
      s.stamp = static_cast<Nanos>(seq) * kNanosPerSecond / 7;
      s.angle_min = static_cast<float>(-std::numbers::pi / 2);
      s.angle_increment = static_cast<float>(0.5 * std::numbers::pi / 180);
      s.n_beams = static_cast<std::uint16_t>(beams.size());
      for (std::size_t k = 0; k < beams.size(); ++k)
        s.ranges_mm[k] = static_cast<std::uint16_t>(beams[k].hit ? std::lround(std::max(0.0, beams[k].range_m) * 1000) : 0);
      s.pose = sensor;
      s.sensor_offset = kMount;
      out.scans.push_back(s);
      traj.points.push_back(robot.translation());
    }
    out.trajectories.push_back(std::move(traj));
  }
  return out;
}

hil::World load_world(const std::string& file) {
  return hil::World::load(std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/" + file);
}

mapper::MapperConfig config_for(const hil::World& world) {
  const auto& b = world.bounds();
  mapper::MapperConfig cfg;  // defaults, bounds from the world plus a margin
  cfg.origin_x = b.xmin - 1.0;
  cfg.origin_y = b.ymin - 1.0;
  cfg.width_m = b.xmax - b.xmin + 2.0;
  cfg.height_m = b.ymax - b.ymin + 2.0;
  return cfg;
}

MapQuality report(const std::string& name, const mapper::Mapper& m, const hil::World& world, const Scans& data) {
  const mapper::ClassGrid map = m.classified();
  const MapQuality q = evaluate(map, world, default_start(world));
  std::printf("%s: %zu scans\n%s", name.c_str(), data.scans.size(), to_text(q).c_str());
  if (const char* dir = std::getenv("CAIRN_MAPPER_FIGURES")) {
    std::filesystem::create_directories(dir);
    const std::string stem = std::string(dir) + "/" + name;
    mapper::write_map_server(map, stem);
    std::vector<msg::Landmark> poles;
    std::uint32_t pid = 0;
    for (const Vec2& p : world.poles()) poles.push_back({++pid, p.x(), p.y(), {0.0025, 0.0, 0.0, 0.0025}});
    mapper::write_png(map, data.trajectories, poles, stem + ".png");
    std::ofstream(stem + "_quality.json") << to_json(q) << "\n";
  }
  return q;
}

MapQuality map_world(const std::string& world_file, const std::vector<std::pair<int, std::vector<Vec2>>>& tours) {
  const hil::World world = load_world(world_file);
  const Scans data = synthesize(world, tours);
  mapper::Mapper m(config_for(world));
  for (const msg::LaserScan& s : data.scans) EXPECT_EQ(m.add_scan(s, s.pose), mapper::Mapper::AddResult::kInserted);
  EXPECT_EQ(m.counters().scans_invalid + m.counters().scans_outside, 0u);
  return report(world_file.substr(0, world_file.find('.')), m, world, data);
}

std::vector<std::pair<int, std::vector<Vec2>>> office_tours(const hil::World& w) {
  return {{1, w.route(1)}, {2, w.route(2)}, {3, w.route(3)}};
}

void expect_bar(const MapQuality& q) {
  EXPECT_GE(q.agreement, 0.97);                       // issue 14: >= 97 % of known cells agree
  EXPECT_LE(q.wall_offset_max_m, q.resolution + 1e-9);  // walls within one cell
  EXPECT_GT(q.coverage, 0.5);                          // and the map is not trivially small
}

// The development check (run before the office figure was looked at): one robot around
// both corridors of environment B on a hand-written tour.
TEST(MapperAccuracy, TwoCorridorsOneTour) {
  expect_bar(map_world("two_corridors.world", {{1, {{1.5, 18.5}, {23.5, 18.5}, {23.5, 1.5}, {1.5, 1.5}, {1.5, 8.75},
                                                {23.5, 8.75}, {23.5, 11.25}, {1.5, 11.25}}}}));
}

TEST(MapperAccuracy, OfficeThreeScriptedTours) {
  expect_bar(map_world("office.world", office_tours(load_world("office.world"))));
}

// Scans placed with wrong poses (each robot's local frame off, and a heading drift growing
// along its tour, as uncorrected odometry would), then corrected: the re-rendered map
// equals the map built at the true poses, cell for cell.
TEST(MapperAccuracy, OfficeCorrectedTrajectoriesRerenderToTheTrueMap) {
  const hil::World world = load_world("office.world");
  const Scans data = synthesize(world, office_tours(world));
  mapper::Mapper truth(config_for(world)), m(config_for(world));
  const auto wrong = [](const msg::LaserScan& s) {
    const Pose2 frame{0.2 * s.robot_id, -0.15, 0.02 * s.robot_id};
    const double drift = 0.01 * static_cast<double>(s.seq) / 100.0;  // 0.01 rad per 100 scans
    return compose(frame, compose(Pose2{0, 0, drift}, s.pose));
  };
  for (const msg::LaserScan& s : data.scans) {
    truth.add_scan(s, s.pose);
    m.add_scan(s, wrong(s));
  }
  const MapQuality before = report("office_uncorrected", m, world, data);
  EXPECT_LT(before.agreement, 0.95);
  // The estimator's corrected trajectory: the true pose at each scan's time.
  std::map<std::pair<std::uint16_t, std::uint32_t>, Pose2> true_pose;
  for (const msg::LaserScan& s : data.scans) true_pose[{s.robot_id, s.seq}] = s.pose;
  for (const std::uint16_t robot : {std::uint16_t{1}, std::uint16_t{2}, std::uint16_t{3}}) {
    const auto st = m.rerender(robot, [&](const mapper::ScanInfo& info) -> std::optional<Pose2> {
      const auto it = true_pose.find({info.robot_id, info.seq});
      if (it == true_pose.end()) return std::nullopt;
      return it->second;
    });
    EXPECT_EQ(st.moved, st.examined);
  }
  std::printf("re-rendered %zu scans\n", data.scans.size());
  int diff = 0;
  for (int j = 0; j < m.geometry().height; ++j)
    for (int i = 0; i < m.geometry().width; ++i) diff += m.log_odds(i, j) != truth.log_odds(i, j);
  EXPECT_EQ(diff, 0);
  expect_bar(report("office_corrected", m, world, data));
}

}  // namespace
}  // namespace cairn::tools
