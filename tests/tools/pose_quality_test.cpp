// Robot trajectories against the bench's ground truth (tools/map_quality/pose_quality.hpp):
// the truth file's reader, the interpolation at each estimate's time, what is not scored,
// and the CSV the base exports (basestation/mapper/export.hpp).
#include "tools/map_quality/pose_quality.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

namespace cairn::tools {
namespace {

constexpr Nanos kT0 = 5'000'000'000;  // the bench's t_s = 0 on CLOCK_MONOTONIC

// Robot 1 drives along x at 1 m/s, robot 2 turns in place through ±π; samples every 0.1 s
// for 2 s, as cairn-hil writes them.
std::string truth_text() {
  std::string t = "# t_s robot x y theta odometer_m (world frame, ground truth)\n# t0_monotonic_ns 5000000000\n";
  char line[128];
  for (int k = 0; k <= 20; ++k) {
    const double s = 0.1 * k;
    std::snprintf(line, sizeof line, "%.3f 1 %.4f 2.0000 0.00000 %.3f\n", s, 1.0 + s, s);
    t += line;
    std::snprintf(line, sizeof line, "%.3f 2 4.0000 4.0000 %.5f 0.000\n", s, normalize_angle(3.0 + s));
    t += line;
  }
  return t;
}

Nanos at(double t_s) { return kT0 + static_cast<Nanos>(std::llround(t_s * 1e9)); }

// The message a reader throws for `text`, or "no error".
template <typename Parse>
std::string error_of(Parse parse, const std::string& text) {
  try {
    parse(text);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(PoseQuality, ReadsTheBenchTruthFile) {
  const GroundTruth g = parse_ground_truth(truth_text(), "truth.txt");
  EXPECT_EQ(g.t0, kT0);
  ASSERT_EQ(g.robots.size(), 2u);
  ASSERT_EQ(g.robots.at(1).size(), 21u);
  EXPECT_DOUBLE_EQ(g.robots.at(1)[10].pose.x, 2.0);
  EXPECT_DOUBLE_EQ(g.robots.at(1)[10].t_s, 1.0);
}

TEST(PoseQuality, RefusesABadTruthFileNamingTheLine) {
  auto message = [](const std::string& text) {
    return error_of([](const std::string& t) { parse_ground_truth(t, "t.txt"); }, text);
  };
  EXPECT_NE(message("0.0 1 1 2 0 0\n").find("no '# t0_monotonic_ns' line"), std::string::npos);
  EXPECT_NE(message("# t0_monotonic_ns 1\n0.0 1 1 2 0\n").find("t.txt:2: expected"), std::string::npos);
  EXPECT_NE(message("# t0_monotonic_ns 1\n0.0 0 1 2 0 0\n").find("t.txt:2: robot id"), std::string::npos);
  EXPECT_NE(message("# t0_monotonic_ns 1\n0.0 1 nan 2 0 0\n").find("t.txt:2: not finite"), std::string::npos);
  EXPECT_NE(message("# t0_monotonic_ns 1\n0.2 1 1 2 0 0\n0.1 1 1 2 0 0\n").find("t.txt:3: time goes backwards"),
            std::string::npos);
}

TEST(PoseQuality, InterpolatesTheTruthAtEachEstimatesTime) {
  const GroundTruth g = parse_ground_truth(truth_text(), "truth.txt");
  // Robot 1 between samples: the truth at 0.55 s is x = 1.55; the estimate is 0.1 m to the
  // side, and one is exact. Robot 2 across ±π: the truth at 0.15 s is 3.15 rad (wrapped).
  const std::vector<mapper::TrajectorySample> est = {
      {1, at(0.55), {1.55, 2.1, 0.0}},
      {1, at(1.25), {2.25, 2.0, 0.0}},
      {2, at(0.15), {4.0, 4.0, normalize_angle(3.15)}},
      {1, at(-0.5), {0.5, 2.0, 0.0}},  // before the truth begins
      {1, at(2.5), {3.5, 2.0, 0.0}},   // after it ends
      {3, at(1.0), {0.0, 0.0, 0.0}},   // a robot the truth does not have
  };
  const PoseQuality q = evaluate_poses(est, g);
  ASSERT_EQ(q.robots.size(), 3u);
  EXPECT_EQ(q.samples, 3u);
  const RobotPoseQuality& r1 = q.robots[0];
  EXPECT_EQ(r1.robot, 1);
  EXPECT_EQ(r1.samples, 2u);
  EXPECT_EQ(r1.unscored, 2u);
  EXPECT_NEAR(r1.rmse_m, std::sqrt(0.01 / 2), 1e-9);
  EXPECT_NEAR(r1.max_m, 0.1, 1e-9);
  const RobotPoseQuality& r2 = q.robots[1];
  EXPECT_EQ(r2.samples, 1u);
  EXPECT_NEAR(r2.rmse_m, 0.0, 1e-9);
  EXPECT_NEAR(r2.heading_rmse_rad, 0.0, 1e-4);  // not 2π: interpolated the short way
  EXPECT_EQ(q.robots[2].unscored, 1u);
  EXPECT_NEAR(q.rmse_m, std::sqrt(0.01 / 3), 1e-9);
}

TEST(PoseQuality, AGapInTheTruthIsNotBridged) {
  GroundTruth g;
  g.t0 = 0;
  g.robots[1] = {{0.0, {0, 0, 0}}, {1.0, {1, 0, 0}}};  // 1 s apart: no interpolation across
  const PoseQuality q = evaluate_poses({{1, 500'000'000, {0.5, 0, 0}}, {1, 1'000'000'000, {1, 0, 0}}}, g);
  EXPECT_EQ(q.robots[0].samples, 1u);  // exactly on the second sample
  EXPECT_EQ(q.robots[0].unscored, 1u);
}

TEST(PoseQuality, TrajectoryCsvRoundTripsAndABadLineIsNamed) {
  namespace fs = std::filesystem;
  const fs::path path = fs::temp_directory_path() / ("cairn_traj_" + std::to_string(::getpid()) + ".csv");
  const std::vector<mapper::TrajectorySample> in = {{1, 123456789, {1.25, -2.5, 0.75}}, {65535, -5, {0, 0, -3.1}}};
  mapper::write_trajectories_csv(in, path.string());
  const auto out = mapper::read_trajectories_csv(path.string());
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].robot, 1);
  EXPECT_EQ(out[0].stamp, 123456789);
  EXPECT_DOUBLE_EQ(out[0].pose.y, -2.5);
  EXPECT_EQ(out[1].robot, 65535);
  EXPECT_EQ(out[1].stamp, -5);
  fs::remove(path);
  auto message = [](const std::string& text) {
    return error_of([](const std::string& t) { mapper::parse_trajectories_csv(t, "t.csv"); }, text);
  };
  EXPECT_NE(message("").find("t.csv: empty"), std::string::npos);
  EXPECT_NE(message("x,y\n").find("t.csv:1: expected the header"), std::string::npos);
  EXPECT_NE(message("robot,t_ns,x,y,theta\n1,5,1,2\n").find("t.csv:2: expected"), std::string::npos);
  EXPECT_NE(message("robot,t_ns,x,y,theta\n1,5,1,2,3,4\n").find("t.csv:2: expected"), std::string::npos);
  EXPECT_NE(message("robot,t_ns,x,y,theta\n0,5,1,2,3\n").find("t.csv:2: robot id"), std::string::npos);
  EXPECT_NE(message("robot,t_ns,x,y,theta\n70000,5,1,2,3\n").find("t.csv:2: robot id"), std::string::npos);
  EXPECT_NE(message("robot,t_ns,x,y,theta\n1,5,inf,2,3\n").find("t.csv:2: a pose that is not finite"), std::string::npos);
}

}  // namespace
}  // namespace cairn::tools
