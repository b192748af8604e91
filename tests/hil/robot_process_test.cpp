// One robot end to end as separate processes, as a user runs them: `cairn-hil robots`
// serves the robot's LMS2xx, CiA 402 drives and power board and writes its
// configuration; the production `cairn-robot` drives route 1 of the office world
// through them; `cairn-base` fuses its topics. The test listens on DDS (loopback
// profile, its own domain) and checks: the route is completed, the robot's local pose
// drifts <= 1 % of the distance (vs the bench's ground truth), each device fault
// (e-stop, laser unplugged, drive silent) is published as a stop with its reason and
// recovered from (the e-stop latches: after its release the robot stays put, publishing
// "reset required", until the operator resets it: `cairn-base --reset-estop 1` (a DDS
// SafetyReset) the first time, SIGUSR1 to cairn-robot the second),
// odometry and features arrive in order, and the base's global pose estimate lies near
// the truth.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "common/dds/participant.hpp"
#include "common/dds/topics.hpp"
#include "basestation/mapper/export.hpp"
#include "hil/world/world.hpp"
#include "tools/map_quality/map_quality.hpp"
#include "tools/map_quality/pose_quality.hpp"
#include "tests/support/subprocess.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using testing::Subprocess;

// Its own DDS domain per run: two checkouts running this test at once on one machine
// (same loopback, same robot id 1) would otherwise read each other's robots.
const int kDomain = 100 + static_cast<int>(getpid() % 100);

std::filesystem::path scratch() {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-robot-process-test-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

void write_file(const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; }

std::string read_file(const std::string& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(RobotProcess, DrivesItsRouteThroughTheRealDriversWithFaultsAndTheBaseFollows) {
  const std::string src = CAIRN_SOURCE_DIR_STR;
  const std::string world_path = src + "/hil/worlds/office.world";
  const hil::World world = hil::World::load(world_path);
  const Pose2 start = *world.start(1);
  const Vec2 goal_local = inverse_transform_point(start, world.route(1).back());

  const auto dir = scratch();
  const std::string dds = "[dds]\nprofile = \"loopback\"\ndomain = " + std::to_string(kDomain) + "\n";
  std::string tmpl = read_file(src + "/config/robot-hil.toml");
  tmpl.replace(tmpl.find("[dds]\nprofile = \"loopback\"\n"), std::string("[dds]\nprofile = \"loopback\"\n").size(), dds);
  write_file(dir / "robot-template.toml", tmpl);
  char base_cfg[1536];
  std::snprintf(base_cfg, sizeof base_cfg,
                "%s[fleet]\ntable_period_s = 5.0\n[fusion]\nstate_dir = \"%s\"\n[mapper]\nexport_dir = \"%s\"\n"
                "[[robot]]\nid = 1\ninitial_pose = [%g, %g, %g]\n",
                dds.c_str(), (dir / "base-state").c_str(), (dir / "map").c_str(), start.x, start.y, start.theta);
  write_file(dir / "base.toml", base_cfg);

  // Faults while driving: e-stop at 15 s, laser unplugged at 25 s, right drive silent at 35 s; 2 s
  // each; the e-stop again at 45 s for 1 s. The first e-stop is reset from the base over DDS,
  // the second with SIGUSR1 (the robot's local reset).
  Subprocess hil({CAIRN_HIL_BIN, "robots", "--world", world_path, "--count", "1", "--template",
                  (dir / "robot-template.toml").string(), "--out", (dir / "robots").string(), "--truth",
                  (dir / "truth.txt").string(), "--report", "2", "--fault", "15:1:estop:2", "--fault", "25:1:laser:2",
                  "--fault", "35:1:drive:2", "--fault", "45:1:estop:1", "--duration", "240"});
  ASSERT_TRUE(hil.wait_for_line("cairn-hil: ready", 10s)) << hil.output();
  Subprocess base({CAIRN_BASE_BIN, "--config", (dir / "base.toml").string(), "--duration", "240"});
  ASSERT_TRUE(base.wait_for_line("starting; DDS profile loopback", 10s)) << base.output();

  dds::Participant pp(dds::loopback_profile(kDomain));
  dds::Topic<cairn_RobotStatus> st(pp);
  dds::Topic<cairn_OdometryIncrement> ot(pp);
  dds::Topic<cairn_FeatureObservations> ft(pp);
  dds::Topic<cairn_PoseCorrection> ct(pp);
  dds::Reader<cairn_RobotStatus> status(pp, st, dds::state_qos(8));
  dds::Reader<cairn_OdometryIncrement> odometry(pp, ot, dds::latched_qos(512));
  dds::Reader<cairn_FeatureObservations> features(pp, ft, dds::latched_qos(512));
  dds::Reader<cairn_PoseCorrection> corrections(pp, ct, dds::latched_qos());

  Subprocess robot({CAIRN_ROBOT_BIN, "--config", (dir / "robots" / "robot-1.toml").string(), "--duration", "240"});
  std::set<int> reasons;
  std::uint32_t last_odom = 0, last_feat = 0, odom_count = 0, feat_count = 0, out_of_order = 0;
  cairn_RobotStatus last{};
  cairn_PoseCorrection corr{};
  bool have_corr = false;
  // The latch: while "reset required" (8) is published the robot must not move; after 1 s
  // of it the test resets: the first time with a SafetyReset, the second with SIGUSR1.
  // A latch that follows "power board silent" (6) rather than the e-stop (1) is the e-stop
  // input going stale for 50 ms: on this loaded 2-core bench (SCHED_OTHER) it can happen;
  // it is reset with SIGUSR1 too, counted and printed.
  std::uint32_t resets_sent = 0, signals_sent = 0, episodes = 0, other_latches = 0;
  bool latched = false, acted = false, estop_episode = false;
  std::uint8_t prev_reason = 0;
  auto latched_since = std::chrono::steady_clock::now();
  cairn_Pose2 latched_pose{};
  double latched_motion = 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto at_goal_since = t0;
  bool at_goal = false;
  while (std::chrono::steady_clock::now() - t0 < 200s) {
    status.wait(50 * kNanosPerMilli);
    status.take([&](const cairn_RobotStatus& s, const dds_sample_info_t&) {
      last = s;
      reasons.insert(s.stop_reason);
    });
    odometry.take([&](const cairn_OdometryIncrement& m, const dds_sample_info_t&) {
      if (m.seq != last_odom + 1) ++out_of_order;
      last_odom = m.seq;
      ++odom_count;
    });
    features.take([&](const cairn_FeatureObservations& m, const dds_sample_info_t&) {
      if (m.seq <= last_feat) ++out_of_order;
      last_feat = m.seq;
      ++feat_count;
    });
    corrections.take([&](const cairn_PoseCorrection& c, const dds_sample_info_t&) {
      corr = c;
      have_corr = true;
    });
    if (last.stop_reason == 8) {
      if (!latched) {
        latched = true;
        acted = false;
        estop_episode = prev_reason == 1;
        if (estop_episode) {
          ++episodes;
        } else {
          ++other_latches;
          std::printf("latched after stop reason %d: %s\n", prev_reason, last.stop_text);
        }
        latched_since = std::chrono::steady_clock::now();
        latched_pose = last.local_pose;
      }
      latched_motion = std::max(latched_motion, std::hypot(last.local_pose.x - latched_pose.x, last.local_pose.y - latched_pose.y));
      if (std::chrono::steady_clock::now() - latched_since > 1s && !acted) {
        acted = true;
        if (estop_episode && episodes == 1) {
          // The operator at the base: `cairn-base --reset-estop 1` sends one SafetyReset.
          Subprocess reset({CAIRN_BASE_BIN, "--config", (dir / "base.toml").string(), "--reset-estop", "1"});
          EXPECT_EQ(reset.wait(10s), 0) << reset.output();
          ++resets_sent;
        } else {
          if (estop_episode) ++signals_sent;
          robot.signal(SIGUSR1);
        }
      }
    } else {
      latched = false;
      prev_reason = last.stop_reason;
    }
    const bool near = std::hypot(last.local_pose.x - goal_local.x(), last.local_pose.y - goal_local.y()) < 0.3;
    if (near && !at_goal) at_goal_since = std::chrono::steady_clock::now();
    at_goal = near;
    if (at_goal && !latched && std::chrono::steady_clock::now() - at_goal_since > 3s) break;  // not while latched: reset first
  }
  std::string seen;
  for (int r : reasons) seen += " " + std::to_string(r);
  ASSERT_TRUE(at_goal) << "route not completed: last local pose " << last.local_pose.x << " " << last.local_pose.y
                       << ", goal " << goal_local.transpose() << "; last stop reason " << static_cast<int>(last.stop_reason)
                       << " (" << last.stop_text << "), mode " << static_cast<int>(last.mode) << ", reasons seen" << seen
                       << ", e-stop episodes " << episodes << ", other latches " << other_latches << ", resets sent "
                       << resets_sent << ", SIGUSR1 sent " << signals_sent << "\n"
                       << robot.output() << "\n" << hil.output();
  const Pose2 local{last.local_pose.x, last.local_pose.y, last.local_pose.theta};
  // The operator asks the running base for its map (SIGUSR1): written at once.
  base.signal(SIGUSR1);
  EXPECT_TRUE(base.wait_for_line("map exported to " + (dir / "map").string() + " (SIGUSR1)", 5s)) << base.output();
  EXPECT_TRUE(std::filesystem::exists(dir / "map" / "map.yaml"));
  std::filesystem::remove_all(dir / "map");
  robot.signal(SIGINT);
  EXPECT_EQ(robot.wait(10s), 0) << robot.output();
  hil.signal(SIGINT);
  EXPECT_EQ(hil.wait(10s), 0);
  base.signal(SIGINT);
  EXPECT_EQ(base.wait(10s), 0);
  // ... and at exit. The central map of this one robot's route, from its LaserScans placed by
  // the base's estimates, against the world's ground truth.
  EXPECT_TRUE(base.wait_for_line("map exported to " + (dir / "map").string() + " (exit)", 1s)) << base.output();
  const mapper::ClassGrid grid = mapper::read_map_server((dir / "map" / "map.yaml").string());
  const tools::MapQuality q = tools::evaluate(grid, world, tools::default_start(world));
  std::printf("base's map of the route: %zu known cells, agreement %.1f %%, wall offset mean %.2f / max %.2f cells\n",
              q.known, 100 * q.agreement, q.wall_offset_mean_cells(), q.wall_offset_max_cells());
  // Runs in real time with injected faults vary: 97.2 % / max 0.97 cell and 95.0 % / 1.51
  // cells were seen on the same tree. Scans placed in wrong frames give ~84 % and walls
  // metres off (docs/mapper.md), which these bounds catch. Under a sanitizer the three
  // processes run several times slower on the same cores: CI's TSan/ASan pass once gave
  // 92.7 % / 2.5 cells (the base's end pose 0.21 m off), so there the bounds are wider,
  // still well clear of wrong frames.
#ifdef CAIRN_SANITIZED
  constexpr double kMinAgreement = 0.90, kMaxWallOffsetCells = 4.0, kMaxPoseRmse = 0.5;
#else
  constexpr double kMinAgreement = 0.93, kMaxWallOffsetCells = 2.0, kMaxPoseRmse = 0.15;
#endif
  const auto fusion_line = base.output().rfind("fusion: odometry");
  std::printf("base's last %s\n", fusion_line == std::string::npos ? "fusion line: none"
                                      : base.output().substr(fusion_line, base.output().find('\n', fusion_line) - fusion_line).c_str());
  EXPECT_GT(q.known, 2000u);
  EXPECT_GE(q.agreement, kMinAgreement);
  EXPECT_LE(q.wall_offset_mean_cells(), 1.0);
  EXPECT_LE(q.wall_offset_max_cells(), kMaxWallOffsetCells);
  // The trajectory the map was built from (the base's trajectories.csv, robot time) against
  // the bench's truth at the same instants: a frame metres off fails here (and, in release,
  // robot and bench clocks a second apart); the end-pose check below sees one instant
  // only. One release run: 370 poses, RMSE 0.084 m, max 0.173 m (the faults included).
  // The sanitizer bound is wide: no sanitized run of this check has been recorded yet.
  const tools::PoseQuality pq = tools::evaluate_poses(mapper::read_trajectories_csv((dir / "map" / "trajectories.csv").string()),
                                                      tools::read_ground_truth((dir / "truth.txt").string()));
  std::printf("base's trajectory against the truth: %zu poses scored, %zu not; rmse %.3f m, max %.3f m\n", pq.samples,
              pq.robots.empty() ? 0 : pq.robots[0].unscored, pq.rmse_m, pq.max_m);
  ASSERT_EQ(pq.robots.size(), 1u);
  EXPECT_GT(pq.samples, 200u);
  EXPECT_LE(pq.robots[0].unscored * 50, pq.samples);  // at most 2 %
  EXPECT_LT(pq.rmse_m, kMaxPoseRmse);

  const auto final_line = hil.wait_for_line("final robot 1 at", 1s);
  ASSERT_TRUE(final_line) << hil.output();
  Pose2 truth;
  double travelled = 0;
  ASSERT_EQ(std::sscanf(final_line->c_str() + final_line->find("at ") + 3, "%lf %lf %lf rad, travelled %lf", &truth.x,
                        &truth.y, &truth.theta, &travelled),
            4)
      << *final_line;
  const Pose2 truth_local = between(start, truth);
  const double drift = std::hypot(local.x - truth_local.x, local.y - truth_local.y);
  std::printf("travelled %.1f m; local pose error %.3f m = %.2f %%; odometry %u, features %u messages; stop reasons seen:",
              travelled, drift, 100 * drift / travelled, odom_count, feat_count);
  for (int r : reasons) std::printf(" %d", r);
  std::printf("\n");
  EXPECT_GT(travelled, 40.0);
  EXPECT_LT(drift, 0.01 * travelled);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_GT(odom_count, 1000u);
  EXPECT_GT(feat_count, 500u);
  EXPECT_TRUE(reasons.count(1)) << "e-stop never published as a stop";
  EXPECT_TRUE(reasons.count(8)) << "the released e-stop never published as latched (reset required)";
  EXPECT_EQ(episodes, 2u) << "e-stop latches (after reason 1)";
  std::printf("latches not caused by the e-stop (stale e-stop input on the loaded bench): %u\n", other_latches);
  EXPECT_EQ(resets_sent, 1u);
  EXPECT_EQ(signals_sent, 1u);
  EXPECT_TRUE(robot.wait_for_line("requested over DDS by 'cairn-base base'", 1s)) << robot.output();
  EXPECT_TRUE(robot.wait_for_line("e-stop reset requested locally (SIGUSR1)", 1s)) << robot.output();  // after the DDS one: lines are read in order
  EXPECT_LT(latched_motion, 0.02) << "the robot moved while its e-stop was latched";
  EXPECT_TRUE(reasons.count(4)) << "laser loss never published as a stop";
  EXPECT_TRUE(reasons.count(2)) << "drive loss never published as a stop";
  EXPECT_EQ(last.stop_reason, 0) << "not recovered: " << last.stop_text;
  // RT timing is not this test's subject (the robot runs SCHED_OTHER beside the emulators,
  // and under sanitizers): executive_hil_test asserts it with the production scheduling
  // (deadline misses, p99 period), cairn-bench-robot-latency the scan's latency.
  EXPECT_EQ(last.n_devices, 4);

  ASSERT_TRUE(have_corr) << "no PoseCorrection from the base\n" << base.output();
  const double global_err = std::hypot(corr.global_pose.x - truth.x, corr.global_pose.y - truth.y);
  std::printf("base station's global pose error at the end: %.3f m\n", global_err);
  EXPECT_LT(global_err, 0.5);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn
