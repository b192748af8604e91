// One robot explores the office world as separate processes, as a user runs them: the HIL
// bench (`cairn-hil robots`, emulated laser, drives and power board), the production
// `cairn-robot` with [explore] enabled (no scripted route: it goes only where the base's
// tasks send it) and `cairn-base` with [explore] enabled. Over DDS on loopback: the base's
// map goes out as MapTiles, the robot keeps it, bids its frontiers (Bid), the base assigns
// (TaskAssignment), the robot plans on its map and drives. After 75 s the base's map must
// cover well beyond what the robot sees from its start (12 % of the office's reachable free
// space, measured with the base's exploration off: the robot then stands), and agree with
// the ground truth.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "basestation/mapper/export.hpp"
#include "hil/world/world.hpp"
#include "tests/support/subprocess.hpp"
#include "tools/map_quality/map_quality.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using testing::Subprocess;

const int kDomain = 100 + static_cast<int>((getpid() + 50) % 100);  // its own per run (robot_process_test: pid % 100)

std::string read_file(const std::string& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The last number after `key` in `text` (the counters of the last summary line), or -1.
long long last_count(const std::string& text, const std::string& key) {
  long long v = -1;
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    v = std::atoll(text.c_str() + at + key.size());
  }
  return v;
}

TEST(ExploreProcess, OneRobotExploresTheOfficeThroughBidsAndTasksOverDds) {
  const std::string src = CAIRN_SOURCE_DIR_STR;
  const std::string world_path = src + "/hil/worlds/office.world";
  const hil::World world = hil::World::load(world_path);
  const Pose2 start = *world.start(1);
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-explore-process-test-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string dds = "[dds]\nprofile = \"loopback\"\ndomain = " + std::to_string(kDomain) + "\n";
  std::string tmpl = read_file(src + "/config/robot-hil.toml");
  tmpl.replace(tmpl.find("[dds]\nprofile = \"loopback\"\n"), std::string("[dds]\nprofile = \"loopback\"\n").size(), dds);
  std::ofstream(dir / "robot-template.toml") << tmpl << "\n[explore]\nenabled = true\n";
  char base_cfg[1024];
  std::snprintf(base_cfg, sizeof base_cfg,
                "%s[fleet]\ntable_period_s = 5.0\n[fusion]\nstate_dir = \"%s\"\n[mapper]\nexport_dir = \"%s\"\n"
                "[explore]\nenabled = true\n[[robot]]\nid = 1\ninitial_pose = [%g, %g, %g]\n",
                dds.c_str(), (dir / "base-state").c_str(), (dir / "map").c_str(), start.x, start.y, start.theta);
  std::ofstream(dir / "base.toml") << base_cfg;

  Subprocess hil({CAIRN_HIL_BIN, "robots", "--world", world_path, "--count", "1", "--template",
                  (dir / "robot-template.toml").string(), "--out", (dir / "robots").string(), "--truth",
                  (dir / "truth.txt").string(), "--report", "5", "--duration", "120"});
  ASSERT_TRUE(hil.wait_for_line("cairn-hil: ready", 10s)) << hil.output();
  Subprocess base({CAIRN_BASE_BIN, "--config", (dir / "base.toml").string(), "--duration", "120"});
  ASSERT_TRUE(base.wait_for_line("explore: assigning frontiers", 10s)) << base.output();
  Subprocess robot({CAIRN_ROBOT_BIN, "--config", (dir / "robots" / "robot-1.toml").string(), "--duration", "120"});
  ASSERT_TRUE(robot.wait_for_text("explore: bidding every", 10s)) << robot.output();

  std::this_thread::sleep_for(75s);  // real time: the bench's devices run on the wall clock
  robot.signal(SIGINT);
  EXPECT_EQ(robot.wait(10s), 0) << robot.output();
  base.signal(SIGINT);
  EXPECT_EQ(base.wait(10s), 0) << base.output();
  hil.signal(SIGINT);
  EXPECT_EQ(hil.wait(10s), 0);

  const std::string robot_out = robot.output(), base_out = base.output();
  // The exchange happened: bids went up, tasks came down, the robot planned them.
  const long long bids = last_count(robot_out, "explore: bids "), plans = last_count(robot_out, "plans ");
  const long long plan_failures = last_count(robot_out, "plans " + std::to_string(plans) + " (failed ");
  const long long assigned = last_count(base_out, "assigned "), taken = last_count(base_out, "explore: exploring; bids ");
  std::printf("robot: bids %lld, plans %lld (failed %lld); base: bids taken %lld, explore tasks assigned %lld\n", bids, plans,
              plan_failures, taken, assigned);
  ASSERT_GE(plan_failures, 0) << "no explore counters line from the robot\n" << robot_out;
  EXPECT_GE(bids, 10) << robot_out;
  EXPECT_GE(taken, 10) << base_out;
  EXPECT_GE(assigned, 2) << base_out;
  EXPECT_GE(plans, 2) << robot_out;
  EXPECT_LE(plan_failures * 4, plans) << "most plans must succeed";

  const auto final_line = hil.wait_for_line("final robot 1 at", 1s);
  ASSERT_TRUE(final_line) << hil.output();
  double x = 0, y = 0, th = 0, travelled = 0;
  ASSERT_EQ(std::sscanf(final_line->c_str() + final_line->find("at ") + 3, "%lf %lf %lf rad, travelled %lf", &x, &y, &th,
                        &travelled),
            4)
      << *final_line;
  ASSERT_TRUE(base.wait_for_line("map exported to " + (dir / "map").string() + " (exit)", 1s)) << base_out;
  const mapper::ClassGrid grid = mapper::read_map_server((dir / "map" / "map.yaml").string());
  const tools::MapQuality q = tools::evaluate(grid, world, tools::default_start(world));
  std::printf("explored 75 s: travelled %.1f m, coverage %.1f %%, agreement %.1f %%, wall offset max %.2f cells\n", travelled,
              100 * q.coverage, 100 * q.agreement, q.wall_offset_max_cells());
  // One run on this tree: 60 % at 90 s (docs/explore.md). Standing at the start: 12 %.
  EXPECT_GT(travelled, 8.0);
  EXPECT_GE(q.coverage, 0.30);
  EXPECT_GE(q.agreement, 0.90);
  EXPECT_LE(q.wall_offset_max_cells(), 2.5);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn
