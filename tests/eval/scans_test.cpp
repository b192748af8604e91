// cairn-eval scans on the real Intel and ACES logs, run as a user would, and the Carmen
// parser on malformed input.
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "tools/datasets/carmen_log.hpp"
#include "tests/support/subprocess.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;
const std::string kData = std::string(CAIRN_SOURCE_DIR_STR) + "/data/radish-corrected-carmen/";

nlohmann::json run_scans(const std::string& log, const std::vector<std::string>& extra) {
  std::vector<std::string> args = {CAIRN_EVAL_BIN, "scans", kData + log, "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  testing::Subprocess p(args);
  EXPECT_EQ(p.wait(240s), 0) << p.output();
  const auto brace = p.output().find('{');
  if (brace == std::string::npos) {
    ADD_FAILURE() << "no JSON in the output";
    return nlohmann::json::object();
  }
  return nlohmann::json::parse(p.output().substr(brace));
}

// The logs are in the repository (data/, with their provenance): these tests run everywhere.
bool have_log(const std::string& log) { return std::filesystem::exists(kData + log); }

// Targets from the issue: median registration error <= 2 cm and 0.5 deg. The reference
// poses are themselves a SLAM estimate; from the reference pose (no perturbation) the
// matcher's median disagreement with it is 2.3 cm on Intel, so that is the floor here.
TEST(EvalScans, IntelPairsAndLocalMapper) {
  ASSERT_TRUE(have_log("intel-corrected.log.gz")) << "no " << kData << "intel-corrected.log.gz (it is in the repository)";
  const auto j = run_scans("intel-corrected.log.gz", {});
  EXPECT_EQ(j["scans"].get<int>(), 910);
  EXPECT_EQ(j["malformed_lines"].get<int>(), 0);
  const auto& p = j["pairs"];
  EXPECT_EQ(p["pairs"].get<int>(), 909);
  EXPECT_LT(p["error_xy_m"]["median"].get<double>(), 0.030);
  EXPECT_LT(p["error_theta_deg"]["median"].get<double>(), 0.5);
  EXPECT_GT(p["success_rate"].get<double>(), 0.93);
  // The perturbation really was applied (the test would pass trivially from the truth).
  EXPECT_GT(p["initial_xy_m"]["median"].get<double>(), 0.08);
  EXPECT_GT(p["mean_nees"].get<double>(), 1.0);
  EXPECT_LT(p["mean_nees"].get<double>(), 6.0);
  const auto& m = j["local_mapper"];
  EXPECT_GT(m["path_m"].get<double>(), 400);
  EXPECT_LT(m["segment_drift_pct"].get<double>(), 2.5);
  EXPECT_LT(m["segment_drift_pct"].get<double>(), m["odometry_segment_drift_pct"].get<double>() / 4);
}

TEST(EvalScans, AcesPairs) {
  ASSERT_TRUE(have_log("aces-corrected.log.gz")) << "no " << kData << "aces-corrected.log.gz (it is in the repository)";
  const auto j = run_scans("aces-corrected.log.gz", {"--no-mapper", "--seed", "3"});
  const auto& p = j["pairs"];
  EXPECT_EQ(p["pairs"].get<int>(), 439);
  EXPECT_LT(p["error_xy_m"]["median"].get<double>(), 0.035);
  EXPECT_LT(p["error_theta_deg"]["median"].get<double>(), 0.5);
  EXPECT_GT(p["success_rate"].get<double>(), 0.88);
  EXPECT_FALSE(j.contains("local_mapper"));
}

TEST(EvalScans, MissingFileIsAClearError) {
  testing::Subprocess p({CAIRN_EVAL_BIN, "scans", "/nonexistent.log"});
  EXPECT_NE(p.wait(10s), 0);
  EXPECT_NE(p.output().find("nonexistent"), std::string::npos) << p.output();
}

TEST(CarmenParser, CountsMalformedLinesAndKeepsGoodOnes) {
  eval::CarmenLog log;
  eval::parse_carmen_line("FLASER 3 1.0 2.0 3.0 0.1 0.2 0.3 0.1 0.2 0.3 12.5 host 12.5", 1, &log);
  eval::parse_carmen_line("FLASER 3 1.0 2.0", 2, &log);                       // truncated
  eval::parse_carmen_line("FLASER -4 1 2 3", 3, &log);                        // bad count
  eval::parse_carmen_line("FLASER 1 nan 0 0 0 0 0 0 1 h 1", 4, &log);         // NaN range
  eval::parse_carmen_line("ODOM 1 2 0.5 0 0 0 7.0 host 7.0", 5, &log);
  eval::parse_carmen_line("ODOM 1 2", 6, &log);
  eval::parse_carmen_line("PARAM robot_frontlaser_offset 0.0 nohost 0", 7, &log);
  eval::parse_carmen_line("# comment", 8, &log);
  ASSERT_EQ(log.scans.size(), 1u);
  EXPECT_EQ(log.scans[0].ranges.size(), 3u);
  EXPECT_DOUBLE_EQ(log.scans[0].pose.x, 0.1);
  EXPECT_DOUBLE_EQ(log.scans[0].stamp, 12.5);
  EXPECT_EQ(log.odom.size(), 1u);
  EXPECT_EQ(log.bad, 4u);
  EXPECT_EQ(log.skipped, 1u);
  ASSERT_GE(log.errors.size(), 1u);
  EXPECT_NE(log.errors[0].find("line 2"), std::string::npos);
}

}  // namespace
}  // namespace cairn
