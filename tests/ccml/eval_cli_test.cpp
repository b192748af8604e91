// cairn-eval ccml-paper, vehicles-needed and mrclam's calibration, run as a user would.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/support/subprocess.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;

TEST(CairnEval, CcmlPaperWritesFiguresAndSummary) {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-eval-test-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  testing::Subprocess p({CAIRN_EVAL_BIN, "ccml-paper", "--scenario", "1", "--out", dir.string(), "--json"});
  ASSERT_EQ(p.wait(120s), 0) << p.output();
  for (const char* f : {"det_vehicle_a.png", "det_feature_1.png", "ellipses.png"}) {
    ASSERT_TRUE(std::filesystem::exists(dir / f)) << f;
    EXPECT_GT(std::filesystem::file_size(dir / f), 2000u) << f;
  }
  const auto j = nlohmann::json::parse(std::ifstream(dir / "summary.json"));
  EXPECT_NEAR(j["cooperative"]["final_over_bound"].get<double>(), 1.0, 0.05);
  EXPECT_NEAR(j["single_vehicle"]["det_vehicle_a_final"].get<double>(), 0.0016, 1e-6);
  EXPECT_TRUE(j["figures_rendered"].get<bool>());
  std::filesystem::remove_all(dir);
}

TEST(CairnEval, VehiclesNeededAndBadArguments) {
  testing::Subprocess p({CAIRN_EVAL_BIN, "vehicles-needed", "--initial-sigma", "0.2", "--desired-sigma", "0.1", "--json"});
  ASSERT_EQ(p.wait(10s), 0);
  const auto j = nlohmann::json::parse(p.output());
  EXPECT_EQ(j["vehicles"].get<int>(), 4);
  testing::Subprocess bad({CAIRN_EVAL_BIN, "ccml-paper", "--scenario", "3"});
  EXPECT_NE(bad.wait(10s), 0);
  EXPECT_NE(bad.output().find("scenario"), std::string::npos);
}

// The documented noise procedure from the command line: fitted on Dataset 6's first 300 s,
// scored after them; a dataset without robot ground truth cannot calibrate.
TEST(CairnEval, MrclamCalibratesOnAHeldOutWindowAndRefusesDatasetsWithoutGroundTruth) {
  const std::string root = std::string(CAIRN_SOURCE_DIR_STR) + "/data/mrclam/MRCLAM_Dataset";
  ASSERT_TRUE(std::filesystem::exists(root + "6/Barcodes.dat.gz")) << "no " << root << "6 (it is in the repository)";
  testing::Subprocess p({CAIRN_EVAL_BIN, "mrclam", root + "6", "--association", "labels", "--calibrate-on", root + "6", "--json"});
  ASSERT_EQ(p.wait(120s), 0) << p.output();
  const auto start = p.output().find("\n{");  // progress lines (stderr) come first on the shared pipe
  ASSERT_NE(start, std::string::npos) << p.output();
  const auto j = nlohmann::json::parse(p.output().substr(start));
  EXPECT_EQ(j["poses_scored_from_s"].get<double>(), 300.0);
  EXPECT_GT(j["noise"]["landmark_sightings"].get<int>(), 1000);
  bool found = false;
  for (const auto& run : j["runs"]) {
    if (run["mode"] != "cooperative-cml") continue;
    found = true;
    double nees = 0;
    for (const auto& r : run["robots"]) nees += r["nees_mean"].get<double>() / 5.0;
    EXPECT_GE(nees, 2.0);
    EXPECT_LE(nees, 4.5);
  }
  EXPECT_TRUE(found) << p.output();
  ASSERT_TRUE(std::filesystem::exists(root + "1/Barcodes.dat.gz")) << "no " << root << "1 (it is in the repository)";
  testing::Subprocess bad({CAIRN_EVAL_BIN, "mrclam", root + "6", "--calibrate-on", root + "1"});
  EXPECT_EQ(bad.wait(60s), 1);
  EXPECT_NE(bad.output().find("needs robot ground truth"), std::string::npos) << bad.output();
}

}  // namespace
}  // namespace cairn
