// The fleet skeleton end to end: a base station and three robots as separate
// processes on the loopback profile. The base lists all three within 3 s; a
// killed robot is reported lost within its liveliness lease; restarted, it reappears.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "tests/support/subprocess.hpp"
#include "tests/support/timing.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using testing::Subprocess;

constexpr int kDomain = 102;
constexpr double kLeaseS = 1.5;

std::string write_config(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-fleet-test-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

std::unique_ptr<Subprocess> start_robot(const std::string& config, int id) {
  return std::make_unique<Subprocess>(
      std::vector<std::string>{CAIRN_ROBOT_BIN, "--config", config, "--id", std::to_string(id), "--duration", "60"});
}

TEST(Fleet, BaseSeesRobotsJoinGetLostAndRejoin) {
  const std::string dds = "[dds]\nprofile = \"loopback\"\ndomain = " + std::to_string(kDomain) + "\n";
  const std::string robot_cfg = write_config("robot.toml", "[robot]\nid = 1\n" + dds +
                                                               "[status]\nperiod_s = 0.5\nliveliness_lease_s = 1.5\n");
  const std::string base_cfg =
      write_config("base.toml", dds + "[fleet]\nstale_after_s = 3.0\ntable_period_s = 1.0\n[fusion]\nenabled = false\n");

  Subprocess base({CAIRN_BASE_BIN, "--config", base_cfg, "--duration", "60"});
  ASSERT_TRUE(base.wait_for_line("starting; DDS profile loopback", 5s)) << base.output();

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::unique_ptr<Subprocess>> robots;
  for (int id = 1; id <= 3; ++id) robots.push_back(start_robot(robot_cfg, id));
  for (int id = 1; id <= 3; ++id) {
    const auto left = 3s - (std::chrono::steady_clock::now() - t0);
    ASSERT_TRUE(base.wait_for_text("robot " + std::to_string(id) + " joined",
                                   std::chrono::duration_cast<std::chrono::milliseconds>(left)))
        << "robot " << id << " not listed within 3 s\n" << base.output();
  }

  // Kill robot 2 without warning: the base must call it lost (not left) within its lease (+0.5 s slack for polling).
  robots[1]->signal(SIGKILL);
  const auto killed = std::chrono::steady_clock::now();
  const auto lost = base.wait_for_line("robot 2 lost", 5s);
  ASSERT_TRUE(lost) << base.output();
  const double lost_after = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  EXPECT_LE(lost_after, (kLeaseS + 0.5) * testing::timing_slack()) << *lost;
  EXPECT_EQ(base.output().find("robot 2 left"), std::string::npos);
  EXPECT_EQ(robots[1]->wait(2s), 128 + SIGKILL);

  // Restart it: it reappears.
  robots[1] = start_robot(robot_cfg, 2);
  ASSERT_TRUE(base.wait_for_line("robot 2 rejoined", 3s)) << base.output();

  // A clean stop is "left", not "lost".
  robots[0]->signal(SIGTERM);
  ASSERT_TRUE(base.wait_for_line("robot 1 left (clean shutdown)", 3s)) << base.output();
  EXPECT_EQ(robots[0]->wait(2s), 0);

  ASSERT_TRUE(base.wait_for_line("fleet: 2 alive", 3s)) << base.output();
  for (auto& r : robots) r->signal(SIGTERM);
  base.signal(SIGTERM);
  EXPECT_EQ(base.wait(3s), 0);
}

TEST(Fleet, BadConfigIsAClearErrorAndNonZeroExit) {
  const std::string cfg = write_config("bad.toml", "[robot]\nid = 999\n");
  Subprocess robot({CAIRN_ROBOT_BIN, "--config", cfg});
  EXPECT_EQ(robot.wait(5s), 2);
  EXPECT_NE(robot.output().find("robot.id: expected an integer in [1, 250], got 999"), std::string::npos) << robot.output();

  const std::string typo = write_config("typo.toml", "[robot]\nid = 3\n[statsu]\nperiod_s = 1.0\n");
  Subprocess robot2({CAIRN_ROBOT_BIN, "--config", typo});
  EXPECT_EQ(robot2.wait(5s), 2);
  EXPECT_NE(robot2.output().find("statsu: unknown key (did you mean 'status'?)"), std::string::npos) << robot2.output();

  Subprocess base({CAIRN_BASE_BIN, "--config", "/nonexistent.toml"});
  EXPECT_EQ(base.wait(5s), 2);
  EXPECT_NE(base.output().find("/nonexistent.toml"), std::string::npos) << base.output();

  Subprocess help({CAIRN_ROBOT_BIN, "--help"});
  EXPECT_EQ(help.wait(5s), 0);
  EXPECT_NE(help.output().find("--config"), std::string::npos);
}

}  // namespace
}  // namespace cairn
