// Real multi-robot data (UTIAS MRCLAM, ../shared/datasets/mrclam): cooperative CML
// against single-robot EKF-SLAM and dead reckoning, and the reader's error handling.
#include "tools/datasets/mrclam.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace cairn::ccml {
namespace {

std::string dataset(int n) {
  return std::string(CAIRN_SOURCE_DIR_STR) + "/../shared/datasets/mrclam/MRCLAM_Dataset" + std::to_string(n);
}

#define REQUIRE_DATASET(n)                                                                      \
  if (!std::filesystem::exists(dataset(n) + "/Barcodes.dat")) GTEST_SKIP() << "no " << dataset(n)

TEST(Mrclam, Dataset6CooperativeBeatsSingleRobotByAtLeast30Percent) {
  REQUIRE_DATASET(6);
  const MrclamData d = load_mrclam(dataset(6));
  ASSERT_TRUE(d.has_robot_groundtruth());
  EXPECT_EQ(d.landmarks.size(), 15u);
  EXPECT_EQ(d.unknown_barcodes_dropped, 6u);  // as counted in PROVENANCE.md
  MrclamOptions o;
  o.mode = MrclamOptions::Mode::kDeadReckoning;
  const MrclamResult dr = run_mrclam(d, o);
  o.mode = MrclamOptions::Mode::kSingleRobot;
  const MrclamResult single = run_mrclam(d, o);
  o.mode = MrclamOptions::Mode::kCooperative;
  const MrclamResult coop = run_mrclam(d, o);
  std::printf("DS6 position RMSE: dead reckoning %.3f, single-robot SLAM %.3f, cooperative CML %.3f m; landmarks %.3f m\n",
              dr.rmse_xy_mean, single.rmse_xy_mean, coop.rmse_xy_mean, coop.landmark_rmse_aligned);
  EXPECT_LT(single.rmse_xy_mean, dr.rmse_xy_mean);
  EXPECT_LE(coop.rmse_xy_mean, 0.7 * single.rmse_xy_mean);
  EXPECT_EQ(coop.features, 15u);
  EXPECT_LT(coop.landmark_rmse_aligned, 0.15);
  for (const auto& r : coop.robots) EXPECT_GT(r.samples, 1000u) << "robot " << r.robot;
}

TEST(Mrclam, Dataset1MapIsAccurateAndItsSwappedLabelsAreFound) {
  REQUIRE_DATASET(1);
  const MrclamData d = load_mrclam(dataset(1));
  EXPECT_FALSE(d.has_robot_groundtruth());
  MrclamOptions o;
  o.duration = 300;
  const MrclamResult coop = run_mrclam(d, o);
  for (const auto& r : coop.robots) EXPECT_TRUE(r.localized) << "robot " << r.robot << " never joined the map";
  EXPECT_EQ(coop.robots[0].localized_at, 0.0);
  EXPECT_GT(coop.robots[1].localized_at, 0.0);  // joined by relocation
  EXPECT_LT(coop.landmark_rmse_label_free, 0.2);
  // In this copy of Dataset 1, landmarks 11 and 17 are swapped relative to Landmark_Groundtruth.dat.
  std::vector<std::pair<int, int>> want = {{11, 17}, {17, 11}};
  EXPECT_EQ(coop.label_mismatches, want);
}

TEST(MrclamReader, ErrorsNameTheFileAndLine) {
  const auto dir = std::filesystem::temp_directory_path() / ("mrclam-bad-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  try {
    load_mrclam(dir.string());
    FAIL() << "missing files must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Barcodes.dat: cannot open"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "Barcodes.dat") << "# header\n 1 5\n 2 x\n";
  try {
    load_mrclam(dir.string());
    FAIL() << "a corrupt line must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Barcodes.dat:3: expected 2 numbers"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn::ccml
