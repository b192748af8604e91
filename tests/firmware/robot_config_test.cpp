// The robot configuration's schema (clear errors naming the key) and the navigator's
// handling of tasks from the base station.
#include <gtest/gtest.h>

#include <cmath>

#include "common/config.hpp"
#include "firmware/navigator.hpp"
#include "firmware/robot_config.hpp"

namespace cairn {
namespace {

const std::string kDevices = "[robot]\nid = 4\n[devices]\nlms = \"tty:/dev/pts/9\"\ncan = \"ucan:/tmp/x\"\npower = \"tcp:127.0.0.1:5020\"\n";

std::string error_of(const std::string& text) {
  try {
    firmware::parse_robot_config(text, "robot.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(RobotConfig, StatusOnlyAndFullRobot) {
  const auto bare = firmware::parse_robot_config("[robot]\nid = 3\n", "robot.toml");
  EXPECT_FALSE(bare.has_devices);
  const auto full = firmware::parse_robot_config(
      kDevices + "[rt]\nperiod_s = 0.005\n[motion]\nwaypoints = [1, 0, 2, 1.5]\nspeed = 0.4\n[safety]\nlink_timeout_s = 0\n",
      "robot.toml");
  EXPECT_TRUE(full.has_devices);
  EXPECT_EQ(full.executive.robot_id, 4);
  EXPECT_EQ(full.executive.lms_uri, "tty:/dev/pts/9");
  EXPECT_EQ(full.executive.period, 5 * kNanosPerMilli);
  EXPECT_EQ(full.executive.master.sync_period, 5 * kNanosPerMilli);
  ASSERT_EQ(full.motion.waypoints.size(), 2u);
  EXPECT_DOUBLE_EQ(full.motion.waypoints[1].y(), 1.5);
  EXPECT_EQ(full.executive.safety.link_timeout, 0);
  EXPECT_EQ(full.executive.feature_period, 0) << "default: features with every scan";
  const auto slow = firmware::parse_robot_config(kDevices + "[mapping]\nfeature_period_s = 0.2\n", "robot.toml");
  EXPECT_EQ(slow.executive.feature_period, 200 * kNanosPerMilli);
  EXPECT_EQ(full.global_map.max_cells, std::size_t{1} << 20) << "default: 1 Mi cells";
  const auto big = firmware::parse_robot_config(kDevices + "[map]\nmax_cells = 4000000\np_o = 0.7\np_c = 0.3\n", "robot.toml");
  EXPECT_EQ(big.global_map.max_cells, 4000000u);
  EXPECT_DOUBLE_EQ(big.global_map.p_o, 0.7);
  EXPECT_DOUBLE_EQ(big.global_map.p_c, 0.3);
  const auto look = firmware::parse_robot_config(
      kDevices + "[motion]\nlookahead_time_s = 2\nlookahead_min = 0.4\nlookahead_max = 0.9\n", "robot.toml");
  EXPECT_DOUBLE_EQ(look.motion.follower.lookahead(0.1), 0.4);
  EXPECT_DOUBLE_EQ(look.motion.follower.lookahead(0.3), 0.6);
  EXPECT_DOUBLE_EQ(look.motion.follower.lookahead(-0.3), 0.6) << "reversing looks as far";
  EXPECT_DOUBLE_EQ(look.motion.follower.lookahead(2.0), 0.9);
  EXPECT_FALSE(look.executive.localmap.map_relative_drift) << "default";
  EXPECT_TRUE(firmware::parse_robot_config(kDevices + "[mapping]\nmap_relative_drift = true\n", "robot.toml")
                  .executive.localmap.map_relative_drift);
}

TEST(RobotConfig, ErrorsNameTheKey) {
  EXPECT_NE(error_of("[robot]\nid = 1\n[devices]\nlms = \"x\"\n").find("devices.can"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "lms_baud = 115200\n").find("lms_baud"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "drive_nodes = [3, 3]\n").find("different node ids"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "lms_resolution_deg = 0.25\n").find("lms_angle_deg = 100"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[motion]\nwaypoints = [1, 2, 3]\n").find("odd count"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[motion]\nlookahead_min = 1\nlookahead_max = 0.5\n").find("motion.lookahead_max"),
            std::string::npos);
  EXPECT_NE(error_of(kDevices + "[rt]\nperiod_s = 0.5\n").find("rt.period_s"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[mapping]\nfeature_period_s = 11\n").find("mapping.feature_period_s"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[map]\nmax_cells = 4095\n").find("map.max_cells"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[map]\nmax_cells = 20000000\n").find("map.max_cells"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[map]\np_c = 0.7\n").find("must be below p_o"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[saftey]\nmax_v = 1\n").find("did you mean 'safety'"), std::string::npos);
}

TEST(RobotConfig, TheProtectiveFieldIsOnByDefaultReadAndKeptInsideTheLaserRange) {
  const auto def = firmware::parse_robot_config(kDevices, "robot.toml");
  EXPECT_TRUE(def.executive.field.enabled);
  const auto set = firmware::parse_robot_config(
      kDevices + "[safety]\nfield_radius_m = 0.4\nfield_reaction_s = 0.2\nreverse_max_v = 0.05\n", "robot.toml");
  EXPECT_EQ(set.executive.field.radius_m, 0.4);
  EXPECT_EQ(set.executive.field.reaction_s, 0.2);
  EXPECT_EQ(set.executive.field.reverse_max_v, 0.05);
  EXPECT_FALSE(firmware::parse_robot_config(kDevices + "[safety]\nfield = false\n", "robot.toml").executive.field.enabled);
  // 4 m/s braking at 0.5 m/s² needs 16 m: beyond the 15 m of returns the robot uses (mapping.max_range_m).
  const std::string why = error_of(kDevices + "[safety]\nmax_v = 4\nmax_acc = 0.5\n");
  EXPECT_NE(why.find("protective field reaches"), std::string::npos) << why;
  EXPECT_NE(why.find("safety"), std::string::npos) << why;
}

TEST(RobotConfig, TheExplorationAreaAndWallGapAreReadAndChecked) {
  const auto def = firmware::parse_robot_config(kDevices, "robot.toml");
  EXPECT_FALSE(def.explore.bidder.has_area);
  EXPECT_DOUBLE_EQ(def.explore.bidder.wall_gap_m, 0.3);
  const auto set = firmware::parse_robot_config(kDevices + "[explore]\narea_m = [-1, -2, 20, 15.5]\nwall_gap_m = 0\n", "robot.toml");
  EXPECT_TRUE(set.explore.bidder.has_area);
  EXPECT_DOUBLE_EQ(set.explore.bidder.area_min_x, -1);
  EXPECT_DOUBLE_EQ(set.explore.bidder.area_min_y, -2);
  EXPECT_DOUBLE_EQ(set.explore.bidder.area_max_x, 20);
  EXPECT_DOUBLE_EQ(set.explore.bidder.area_max_y, 15.5);
  EXPECT_DOUBLE_EQ(set.explore.bidder.wall_gap_m, 0);
  EXPECT_NE(error_of(kDevices + "[explore]\narea_m = [5, 0, 1, 3]\n").find("explore.area_m"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[explore]\narea_m = [0, 0, 1]\n").find("explore.area_m"), std::string::npos);
  EXPECT_NE(error_of(kDevices + "[explore]\nwall_gap_m = 2\n").find("explore.wall_gap_m"), std::string::npos);
}

TEST(RobotConfig, TheKeepRightBarrierIsReadAndChecked) {
  const auto def = firmware::parse_robot_config(kDevices, "robot.toml");
  EXPECT_DOUBLE_EQ(def.explore.blocks.keep_right_m, 1.0);
  EXPECT_EQ(def.explore.blocks.keep_right_memory, 5 * kNanosPerSecond);
  const auto set = firmware::parse_robot_config(
      kDevices + "[explore]\nblocked_keep_right_m = 0\nblocked_keep_right_s = 2.5\n", "robot.toml");
  EXPECT_DOUBLE_EQ(set.explore.blocks.keep_right_m, 0.0);
  EXPECT_EQ(set.explore.blocks.keep_right_memory, 2500 * kNanosPerMilli);
  EXPECT_NE(error_of(kDevices + "[explore]\nblocked_keep_right_m = 9\n").find("explore.blocked_keep_right_m"),
            std::string::npos);
  EXPECT_NE(error_of(kDevices + "[explore]\nblocked_keep_right_s = -1\n").find("explore.blocked_keep_right_s"),
            std::string::npos);
}

TEST(RobotConfig, RefusesALocalMapWhoseWorkDoesNotFitTheRtPeriod) {
  // 1 cm cells passed the local map's own validation; the search alone is ~20 ms a scan.
  const std::string why = error_of(kDevices + "[mapping]\ngrid_resolution_m = 0.01\n");
  EXPECT_NE(why.find("mapping: local map: worst-case per-scan matching"), std::string::npos) << why;
  EXPECT_NE(why.find("exceeds the budget 5.0 ms (50 % of the 10.0 ms RT period)"), std::string::npos) << why;
  // The default map fits even a 5 ms period; a 1 ms one it does not.
  EXPECT_EQ(error_of(kDevices + "[rt]\nperiod_s = 0.005\n"), "");
  EXPECT_NE(error_of(kDevices + "[rt]\nperiod_s = 0.001\n").find("of the 1.0 ms RT period"), std::string::npos);
  // Keyframes faster than the rebuild: 100 keyframes of a 0.5° scan turning at 5 rad/s.
  EXPECT_NE(error_of(kDevices + "[safety]\nmax_w = 5\n[mapping]\nkeyframes = 100\n").find("keyframe rebuild"),
            std::string::npos);
  // Status-only robots run no executive: nothing to check.
  EXPECT_EQ(error_of("[robot]\nid = 3\n[rt]\nperiod_s = 0.001\n"), "");
}

msg::TaskAssignment goto_task(std::uint32_t id, double x, double y) {
  msg::TaskAssignment t{};
  t.robot_id = 1;
  t.task_id = id;
  t.kind = msg::TaskKind::kGoto;
  t.target_x = x;
  t.target_y = y;
  return t;
}

TEST(Navigator, GotoIsFollowedInTheLocalFrameThroughTheCorrection) {
  firmware::MotionConfig m;
  firmware::Navigator nav(m);
  double v = 1, w = 1;
  nav.command({}, 0.0, &v, &w);
  EXPECT_EQ(v, 0.0);  // no route, no task: stand still
  EXPECT_NE(nav.on_task(goto_task(7, 10, 5), std::nullopt).find("no PoseCorrection"), std::string::npos);
  EXPECT_FALSE(nav.active());
  // Local frame = global rotated by 90° and shifted to (10, 3): the global target (10, 5)
  // lies 2 m straight ahead of the local origin.
  const Pose2 local_to_global{10, 3, M_PI / 2};
  EXPECT_EQ(nav.on_task(goto_task(8, 10, 5), local_to_global), "");
  EXPECT_TRUE(nav.active());
  nav.command({}, 0.0, &v, &w);
  EXPECT_GT(v, 0.0);
  EXPECT_NEAR(w, 0.0, 1e-6);
  auto nan_task = goto_task(9, std::nan(""), 0);
  EXPECT_NE(nav.on_task(nan_task, local_to_global).find("non-finite"), std::string::npos);
  msg::TaskAssignment stop{};
  stop.task_id = 10;
  stop.kind = msg::TaskKind::kStop;
  EXPECT_EQ(nav.on_task(stop, local_to_global), "");
  EXPECT_FALSE(nav.active());
}

TEST(Navigator, ARestartedBasesTaskWithAnOldIdIsNotTakenForARepeat) {
  firmware::MotionConfig m;
  firmware::Navigator nav(m);
  const Pose2 local_to_global{0, 0, 0};
  ASSERT_EQ(nav.on_task(goto_task(1, 4, 0), local_to_global), "");
  msg::TaskAssignment idle{};
  idle.task_id = 2;
  idle.kind = msg::TaskKind::kIdle;
  ASSERT_EQ(nav.on_task(idle, local_to_global), "");
  EXPECT_FALSE(nav.active());
  // The same task again (the latched topic's repeat) changes nothing.
  ASSERT_EQ(nav.on_task(idle, local_to_global), "");
  EXPECT_FALSE(nav.active());
  // The base restarted and numbers its tasks from 1 again: task 2 is now a goto elsewhere.
  // The old navigator took the id alone for a repeat and stood still.
  ASSERT_EQ(nav.on_task(goto_task(2, 0, 3), local_to_global), "");
  EXPECT_TRUE(nav.active());
  double v = 0, w = 0;
  nav.command({}, 0.0, &v, &w);
  EXPECT_GT(w, 0.0) << "turning towards (0, 3)";
}

}  // namespace
}  // namespace cairn
