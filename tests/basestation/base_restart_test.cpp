// The base station killed mid-run resumes without losing an observation: the robots'
// transient-local history covers the outage, the write-ahead log covers what the base
// had applied, and duplicates are recognised by sequence number.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>

#include "tests/support/subprocess.hpp"
#include "tests/support/timing.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using testing::Subprocess;

struct Counts {
  long odometry = -1, features = -1;
};

// "... final fusion: odometry N applied (...), features M applied (...)"
Counts parse_final(const std::string& out) {
  Counts c;
  const auto at = out.find("final fusion: odometry ");
  if (at == std::string::npos) return c;
  const auto feat = out.find("features ", at);
  if (feat == std::string::npos) return c;
  c.odometry = std::atol(out.c_str() + at + std::string("final fusion: odometry ").size());
  c.features = std::atol(out.c_str() + feat + 9);
  return c;
}

TEST(BaseRestart, KilledBaseResumesWithoutLosingAnObservation) {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-base-restart-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string cfg = (dir / "base.toml").string();
  std::ofstream(cfg) << "[dds]\nprofile = \"loopback\"\ndomain = 103\n"
                     << "[fusion]\nstate_dir = \"" << (dir / "state").string() << "\"\nsnapshot_period_s = 1.0\n"
                     << "[[robot]]\nid = 1\ninitial_pose = [-2.0, -1.0, 0.0]\n"
                     << "[[robot]]\nid = 2\ninitial_pose = [0.0, -0.5, 0.3]\n"
                     << "[[robot]]\nid = 3\ninitial_pose = [2.0, 0.0, 0.6]\n";
  const int robots = 3, steps = 400;  // 1200 odometry + 600 feature messages over ~8 s
  auto base = std::make_unique<Subprocess>(std::vector<std::string>{CAIRN_BASE_BIN, "--config", cfg, "--duration", "60"});
  ASSERT_TRUE(base->wait_for_text("fusion: state in", 5s)) << base->output();
  Subprocess feeder({CAIRN_FEEDER_BIN, "--domain", "103", "--robots", std::to_string(robots), "--steps",
                     std::to_string(steps), "--rate", "50"});
  ASSERT_TRUE(feeder.wait_for_text("feeder: 333 odometry", 20s)) << feeder.output();
  // Kill the base mid-run, keep it down for a while (the feeder keeps publishing), restart it.
  base->signal(SIGKILL);
  base->wait(2s);
  const std::string first_run = base->output();
  std::this_thread::sleep_for(1500ms);
  base = std::make_unique<Subprocess>(std::vector<std::string>{CAIRN_BASE_BIN, "--config", cfg, "--duration", "60"});
  ASSERT_TRUE(base->wait_for_text("snapshot loaded", 5s)) << base->output();
  ASSERT_TRUE(feeder.wait_for_text("feeder: done", 30s)) << feeder.output();
  // Wait until the last messages arrived (reliable, so they do: transport time, longer in
  // sanitizer builds): the base's periodic console line shows every one applied.
  const auto settle = std::chrono::milliseconds(static_cast<int>(10000 * testing::timing_slack()));
  ASSERT_TRUE(base->wait_for_text("fusion: odometry " + std::to_string(robots * steps) + " applied", settle)) << base->output();
  ASSERT_TRUE(base->wait_for_text("features " + std::to_string(robots * steps / 2) + " applied", settle)) << base->output();
  base->signal(SIGTERM);
  ASSERT_EQ(base->wait(5s), 0) << base->output();
  const Counts c = parse_final(base->output());
  EXPECT_EQ(c.odometry, robots * steps) << base->output();
  EXPECT_EQ(c.features, robots * steps / 2) << base->output();
  EXPECT_NE(base->output().find("dup"), std::string::npos);
  feeder.signal(SIGTERM);
  feeder.wait(5s);
  std::filesystem::remove_all(dir);
  (void)first_run;
}

}  // namespace
}  // namespace cairn
