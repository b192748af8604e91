// Real multi-robot data (UTIAS MRCLAM, data/mrclam): cooperative CML
// against single-robot EKF-SLAM and dead reckoning, the reader's error handling, and a
// small hand-made dataset (a robot whose ground truth starts late).
#include "tools/datasets/mrclam.hpp"
#include "tools/datasets/mrclam_base.hpp"
#include "tools/datasets/mrclam_calibration.hpp"
#include "tools/datasets/read_text.hpp"

#include <gtest/gtest.h>

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <vector>
#include <cstdio>
#include <numbers>
#include <random>

namespace cairn::ccml {
namespace {

std::string dataset(int n) {
  return std::string(CAIRN_SOURCE_DIR_STR) + "/data/mrclam/MRCLAM_Dataset" + std::to_string(n);
}

// The data is in the repository (data/mrclam, gzipped): missing, it is a failure, not a skip.
#define REQUIRE_DATASET(n) \
  ASSERT_TRUE(std::filesystem::exists(dataset(n) + "/Barcodes.dat.gz")) << "no " << dataset(n)

// The data in data/ is gzipped: a .gz and its plain text read the same, and a truncated
// .gz is an error naming the file, not a shorter table.
TEST(ReadText, GzipAndPlainReadTheSameAndATruncatedGzipIsAnError) {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-read-text-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::string text;
  for (int i = 0; i < 20000; ++i) text += std::to_string(i) + " 0.5 -1.25\r\n";
  const std::string plain = (dir / "t.dat").string(), gz = (dir / "u.dat.gz").string(), cut = (dir / "cut.dat.gz").string();
  std::ofstream(plain, std::ios::binary) << text;
  gzFile f = gzopen(gz.c_str(), "wb9");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  ASSERT_EQ(gzclose(f), Z_OK);
  EXPECT_EQ(datasets::read_text_file(plain), text);
  EXPECT_EQ(datasets::read_text_file(gz), text);
  EXPECT_EQ(datasets::plain_or_gz((dir / "u.dat").string()), gz);
  EXPECT_EQ(datasets::plain_or_gz(plain), plain);
  EXPECT_FALSE(datasets::read_text_file((dir / "none.dat").string()).has_value());
  std::ifstream in(gz, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 100u);
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(datasets::read_text_file(cut), std::runtime_error);
  std::filesystem::remove_all(dir);
}

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
  for (const auto& r : coop.robots) {
    EXPECT_GT(r.samples, 1000u) << "robot " << r.robot;
    EXPECT_LT(r.rmse_xy, 0.5) << "robot " << r.robot;  // robot 4 too: its ground truth starts 15 ms late (issue 16)
  }
}

// The noise model chosen by the written-down procedure (mrclam_calibration.hpp), fitted
// on Dataset 6's first 300 s only, and the labelled cooperative run scored on the 600 s
// after them: its pose NEES must be consistent (issue 16 item 5: mean in [2, 4.5] for
// 3 degrees of freedom; the hand-picked defaults give 8).
TEST(Mrclam, Dataset6NoiseCalibratedOnItsFirst300SecondsIsConsistentOnTheRest) {
  REQUIRE_DATASET(6);
  const MrclamData d = load_mrclam(dataset(6));
  const MrclamNoiseFit fit = calibrate_mrclam(d, 300);
  std::printf("fit: %zu sightings, range %.3f m, bearing %.4f rad; %zu windows, odometry x %.3f + %.3f, heading %.3f + %.3f, "
              "factor %.2f, calibration NEES %.2f\n",
              fit.measurements, fit.range_sigma, fit.bearing_sigma, fit.odometry_windows, fit.odom_v_rel, fit.odom_v_rate,
              fit.odom_w_rel, fit.odom_w_rate, fit.odometry_factor, fit.calibration_nees);
  EXPECT_GT(fit.measurements, 1000u);
  EXPECT_GT(fit.odometry_windows, 1000u);
  EXPECT_GT(fit.range_sigma, 0.0);
  EXPECT_GT(fit.bearing_sigma, 0.0);
  EXPECT_LT(fit.odometry_factor, 16.0) << "the consistency factor hit the top of its grid";
  MrclamOptions o;
  apply_noise(fit, &o);
  o.score_from = 300;
  const MrclamResult coop = run_mrclam(d, o);
  double nees = 0;
  for (const auto& r : coop.robots) {
    EXPECT_GT(r.samples, 1000u) << "robot " << r.robot;
    nees += r.nees_mean / static_cast<double>(coop.robots.size());
  }
  std::printf("held out (300-900 s): cooperative RMSE %.3f m, mean NEES %.2f\n", coop.rmse_xy_mean, nees);
  EXPECT_GE(nees, 2.0);
  EXPECT_LE(nees, 4.5);
  EXPECT_LT(coop.rmse_xy_mean, 0.3);
  // The calibration window is really left out: the last 600 of 900 s hold 59-65 % of each
  // robot's odometry samples; all of them if it were not.
  o.score_from = 0;
  const MrclamResult all = run_mrclam(d, o);
  for (std::size_t r = 0; r < all.robots.size(); ++r) {
    const double share = static_cast<double>(coop.robots[r].samples) / static_cast<double>(all.robots[r].samples);
    std::printf("robot %d: %.3f of its samples scored\n", all.robots[r].robot, share);
    EXPECT_GT(share, 0.5) << "robot " << all.robots[r].robot;
    EXPECT_LT(share, 0.8) << "robot " << all.robots[r].robot;
  }
}

TEST(Mrclam, CalibrationNeedsRobotGroundTruth) {
  REQUIRE_DATASET(1);
  EXPECT_THROW(calibrate_mrclam(load_mrclam(dataset(1)), 300), std::invalid_argument);
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

// The base station's own Fusion fed with the robots' messages (mrclam_base.hpp): what a
// live base does with these robots, landmarks without labels (issue 16 item 5).
void print_base_run(const char* what, const MrclamResult& r) {
  std::printf("%s: %zu features, %zu landmarks matched, landmark RMSE label-free %.3f m, aligned %.3f m; robot RMSE %.3f m; "
              "%zu observations used, %zu rejected\n",
              what, r.features, r.landmarks_matched, r.landmark_rmse_label_free, r.landmark_rmse_aligned, r.rmse_xy_mean,
              r.measurements_used, r.measurements_rejected);
  for (const auto& x : r.robots) {
    std::printf("  robot %d: localized %d at %.1f s, RMSE %.3f m, NEES %.1f\n", x.robot, x.localized, x.localized_at, x.rmse_xy,
                x.nees_mean);
  }
}

// Dataset 6 (robots known at their first ground-truth pose): the base keeps the map to
// 17 features for the 15 landmarks; its robot error is about twice the labelled run's
// (robots' positions: 0.53 vs 0.25 m; the 1.5x is met by the harness's JCBB, not by
// the base's rules).
TEST(MrclamBase, Dataset6TheBasesFusionWithoutLabels) {
  REQUIRE_DATASET(6);
  const MrclamData d = load_mrclam(dataset(6));
  const MrclamResult labelled = run_mrclam(d, MrclamOptions{});
  const MrclamResult base = run_mrclam_base(d, MrclamOptions{});
  print_base_run("DS6 base-fusion", base);
  std::printf("DS6 labelled cooperative CML: robot RMSE %.3f m\n", labelled.rmse_xy_mean);
  EXPECT_FALSE(base.association_errors_known);
  for (const auto& r : base.robots) EXPECT_TRUE(r.localized) << "robot " << r.robot;
  EXPECT_LE(base.features, 20u);
  EXPECT_GE(base.landmarks_matched, 10u);
  EXPECT_LT(base.landmark_rmse_label_free, 0.8);  // 0.667 m when written
  EXPECT_LT(base.rmse_xy_mean, 2.5 * labelled.rmse_xy_mean);
}

// Dataset 1 (robots 2-5 join by relocation): the base's rules (the strict new-feature gate,
// tentative landmarks pruned) leave half the features of the harness's JCBB, still far
// from the 15 landmarks (issue 16 item 5 asks for at most 20).
TEST(MrclamBase, Dataset1TheBasesRulesHalveTheHarnessDuplicates) {
  REQUIRE_DATASET(1);
  const MrclamData d = load_mrclam(dataset(1));
  MrclamOptions o;
  o.association = MrclamOptions::Association::kJcbb;
  const MrclamResult harness = run_mrclam(d, o);
  const MrclamResult base = run_mrclam_base(d, MrclamOptions{});
  print_base_run("DS1 base-fusion", base);
  std::printf("DS1 harness cooperative CML with JCBB: %zu features\n", harness.features);
  for (const auto& r : base.robots) EXPECT_TRUE(r.localized) << "robot " << r.robot;
  EXPECT_LT(static_cast<double>(base.features), 0.6 * static_cast<double>(harness.features));
  EXPECT_LE(base.features, 120u);  // 103 when written; the goal is 20
}

// A hand-made dataset: five robots standing still, then driving straight at 0.5 m/s;
// odometry and ground truth agree exactly, so every estimator should track ground truth.
// Robot 4's ground truth starts 0.5 s after the others' (as in Dataset 6, by 15 ms): it
// joins the estimate at its first ground-truth sample, from that pose (issue 16: it used
// to start from an empty optional, i.e. garbage).
class MrclamLateGroundTruth : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("mrclam-late-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
    std::ofstream(dir_ / "Barcodes.dat") << "# Subject # Barcode #\n1 5\n2 14\n3 41\n4 32\n5 23\n6 63\n";
    std::ofstream(dir_ / "Landmark_Groundtruth.dat") << "# Subject # x [m] y [m] x std-dev [m] y std-dev [m]\n6 0 0 0 0\n";
    for (int r = 1; r <= 5; ++r) {
      const double x0 = r == 4 ? 7.5 : r, y0 = r == 4 ? -3.25 : -r, th = r == 4 ? 1.0 : 0.3 * r;
      const double t_gt = r == 4 ? kT0 + 0.5 : kT0, t_move = kT0 + 2;
      std::ofstream gt(dir_ / ("Robot" + std::to_string(r) + "_Groundtruth.dat"));
      std::ofstream odo(dir_ / ("Robot" + std::to_string(r) + "_Odometry.dat"));
      std::ofstream(dir_ / ("Robot" + std::to_string(r) + "_Measurement.dat")) << "# Time [s] Subject # range [m] bearing [rad]\n";
      gt << std::fixed << std::setprecision(6);
      odo << std::fixed << std::setprecision(6);
      for (int k = 0; k <= 100; ++k) {  // 10 s at 10 Hz
        const double t = kT0 + 0.1 * k;
        const double d = 0.5 * std::max(0.0, t - t_move);
        if (t >= t_gt - 1e-9) gt << t << ' ' << x0 + d * std::cos(th) << ' ' << y0 + d * std::sin(th) << ' ' << th << '\n';
        if (t >= t_move - 1e-9) odo << t << " 0.5 0\n";
      }
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  static constexpr double kT0 = 1248444175.0;
  std::filesystem::path dir_;
};

TEST_F(MrclamLateGroundTruth, ARobotWhoseGroundTruthStartsLateJoinsAtItsFirstSample) {
  const MrclamData d = load_mrclam(dir_.string());
  ASSERT_TRUE(d.has_robot_groundtruth());
  for (auto mode : {MrclamOptions::Mode::kDeadReckoning, MrclamOptions::Mode::kSingleRobot, MrclamOptions::Mode::kCooperative}) {
    MrclamOptions o;
    o.mode = mode;
    const MrclamResult res = run_mrclam(d, o);
    ASSERT_EQ(res.robots.size(), 5u);
    for (const auto& r : res.robots) {
      EXPECT_GT(r.samples, 50u) << mode_name(mode) << " robot " << r.robot;
      EXPECT_LT(r.rmse_xy, 1e-6) << mode_name(mode) << " robot " << r.robot;  // -1 (unscored) fails the next line
      EXPECT_GE(r.rmse_xy, 0.0) << mode_name(mode) << " robot " << r.robot;
      EXPECT_LT(r.nees_mean, 1e-3) << mode_name(mode) << " robot " << r.robot;
      EXPECT_TRUE(r.localized) << mode_name(mode) << " robot " << r.robot;
    }
    EXPECT_NEAR(res.robots[3].localized_at, 0.5, 1e-6) << mode_name(mode);  // from its first ground-truth sample
    EXPECT_EQ(res.robots[0].localized_at, 0.0) << mode_name(mode);
  }
}

// The calibration procedure on a made dataset whose noise is known, so that it runs on
// any machine without the real data too: five robots circling four landmarks for 320 s, every
// sighting's range and bearing perturbed with σ 0.10 m and 0.02 rad. Step 1 must recover
// both; a residual taken in the wrong frame or a wrong spread estimate does not.
TEST(MrclamCalibration, RecoversTheMeasurementNoiseOfAMadeDataset) {
  constexpr double kT0 = 1248444175.0, kRangeSigma = 0.10, kBearingSigma = 0.02;
  const auto dir = std::filesystem::temp_directory_path() / ("mrclam-calib-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "Barcodes.dat") << "1 5\n2 14\n3 41\n4 32\n5 23\n6 63\n7 64\n8 65\n9 66\n";
  const std::vector<Vec2> lm = {{3, 3}, {-3, 3}, {-3, -3}, {3, -3}};
  {
    std::ofstream f(dir / "Landmark_Groundtruth.dat");
    for (std::size_t k = 0; k < lm.size(); ++k) f << 6 + k << ' ' << lm[k].x() << ' ' << lm[k].y() << " 0 0\n";
  }
  std::mt19937 rng(7);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int r = 1; r <= 5; ++r) {
    std::ofstream gt(dir / ("Robot" + std::to_string(r) + "_Groundtruth.dat"));
    std::ofstream odo(dir / ("Robot" + std::to_string(r) + "_Odometry.dat"));
    std::ofstream meas(dir / ("Robot" + std::to_string(r) + "_Measurement.dat"));
    gt << std::fixed << std::setprecision(6);
    odo << std::fixed << std::setprecision(6);
    meas << std::fixed << std::setprecision(6);
    // A circle of radius 1.5 + 0.2 r about the origin, at 0.3 m/s; the true speed wanders
    // about the commanded one, so the odometry has an error to fit too.
    const double radius = 1.5 + 0.2 * r, v = 0.3, w = v / radius;
    Pose2 p{radius, 0, std::numbers::pi / 2};
    for (int k = 0; k <= 32000; ++k) {  // 320 s at 100 Hz
      const double t = kT0 + 0.01 * k;
      gt << t << ' ' << p.x << ' ' << p.y << ' ' << p.theta << '\n';
      if (k % 2 == 0) odo << t << ' ' << v << ' ' << w << '\n';
      if (k % 50 == 0) {
        for (std::size_t l = 0; l < lm.size(); ++l) {
          const RangeBearing z = observe_point(p, lm[l]);
          meas << t << ' ' << 63 + l << ' ' << z.range + kRangeSigma * unit(rng) << ' '
               << normalize_angle(z.bearing + kBearingSigma * unit(rng)) << '\n';
        }
      }
      p = compose(p, arc_motion(v * (1 + 0.2 * unit(rng)), w * (1 + 0.2 * unit(rng)), 0.01));
    }
  }
  const MrclamData d = load_mrclam(dir.string());
  const MrclamNoiseFit fit = calibrate_mrclam(d, 300);
  std::printf("made dataset: range %.4f m, bearing %.5f rad from %zu sightings; odometry x %.3f + %.4f, heading %.3f + %.4f, "
              "factor %.2f\n",
              fit.range_sigma, fit.bearing_sigma, fit.measurements, fit.odom_v_rel, fit.odom_v_rate, fit.odom_w_rel,
              fit.odom_w_rate, fit.odometry_factor);
  EXPECT_GT(fit.measurements, 10000u);
  EXPECT_NEAR(fit.range_sigma, kRangeSigma, 0.1 * kRangeSigma);
  EXPECT_NEAR(fit.bearing_sigma, kBearingSigma, 0.1 * kBearingSigma);
  EXPECT_NEAR(fit.range_median, 0.0, 0.01);
  EXPECT_NEAR(fit.bearing_median, 0.0, 0.002);
  EXPECT_GT(fit.odometry_windows, 1000u);
  EXPECT_GT(fit.odom_v_rel + fit.odom_v_rate, 0.0) << "the speed error was not seen";
  EXPECT_GT(fit.calibration_nees, 0.0);
  std::filesystem::remove_all(dir);
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
