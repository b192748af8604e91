// RobotCore, the robot pipeline without threads, devices or a clock, driven call by call
// on simulated time: what it emits per scan (sequence, boot epoch, the link from features
// to their odometry, every Nth LaserScan) and where it cuts the wheel odometry (at the
// scan's mid-sweep, splitting the wheel sample that spans it).
#include "firmware/executive/robot_core.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "common/log.hpp"
#ifdef CAIRN_COUNT_ALLOCS
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn {
namespace {

struct Recorder : firmware::RobotOutputs {
  std::vector<msg::OdometryIncrement> increments;
  std::vector<msg::LaserScan> lasers;
  std::vector<msg::FeatureObservations> observations;
  void odometry(const msg::OdometryIncrement& m) override { increments.push_back(m); }
  void laser(const msg::LaserScan& m) override { lasers.push_back(m); }
  void features(const msg::FeatureObservations& m) override { observations.push_back(m); }
};

constexpr Nanos kMs = kNanosPerMilli;

// A 180°, 0.5° scan taken at `stamp`: no echo except, if `pole`, a reflective patch of five
// beams 3 m straight ahead.
lms::LmsScan scan_at(Nanos stamp, bool pole) {
  lms::LmsScan s;
  s.stamp = stamp;
  s.count = 361;
  s.angle_min = -M_PI / 2;
  s.angle_increment = 0.5 * M_PI / 180;
  s.beam_period_s = 0.5 / 360.0 / 75.0;
  if (pole) {
    for (int i = 178; i <= 182; ++i) {
      s.range_mm[static_cast<std::size_t>(i)] = 3000;
      s.flags[static_cast<std::size_t>(i)] = 1;
    }
  }
  return s;
}

// Straight ahead at `v` m/s: the wheel positions at time t (right motor mirrored).
firmware::WheelReading wheels_at(const canopen::DiffDriveGeometry& g, double v, Nanos t) {
  const double counts = v * nanos_to_seconds(t) / g.wheel_radius_m * g.counts_per_wheel_rad();
  firmware::WheelReading w;
  w.left = static_cast<std::int32_t>(std::lround(counts));
  w.right = static_cast<std::int32_t>(std::lround(g.right_inverted ? -counts : counts));
  w.enabled = true;
  w.stamp = t;
  return w;
}

TEST(RobotCore, MessagesCarryTheBootEpochSequenceAndOdometryLink) {
  firmware::ExecutiveConfig cfg;
  cfg.robot_id = 7;
  cfg.boot_epoch = 0xCAFEu;
  cfg.scan_publish_every = 4;
  firmware::RobotCore core(cfg);
  Recorder out;
  for (int k = 0; k < 10; ++k) {
    const Nanos t = (k + 1) * 27 * kMs;
    core.on_wheels(wheels_at(cfg.geometry, 0.0, t));
    core.on_scan(scan_at(t - 10 * kMs, /*pole=*/true), t, out);
  }
  ASSERT_EQ(out.increments.size(), 10u);
  for (std::size_t i = 0; i < out.increments.size(); ++i) {
    EXPECT_EQ(out.increments[i].robot_id, 7);
    EXPECT_EQ(out.increments[i].boot_epoch, 0xCAFEu);
    EXPECT_EQ(out.increments[i].seq, i + 1);
    EXPECT_EQ(out.increments[i].t1, static_cast<Nanos>(i + 1) * 27 * kMs - 10 * kMs);
    if (i > 0) {
      EXPECT_EQ(out.increments[i].t0, out.increments[i - 1].t1) << "increments must tile time";
    }
  }
  // Every 4th scan: scans 4 and 8.
  ASSERT_EQ(out.lasers.size(), 2u);
  EXPECT_EQ(out.lasers[0].seq, 1u);
  EXPECT_EQ(out.lasers[1].stamp, out.increments[7].t1);
  ASSERT_EQ(out.observations.size(), 10u) << "the pole straight ahead, seen in every scan";
  for (std::size_t i = 0; i < out.observations.size(); ++i) {
    EXPECT_EQ(out.observations[i].boot_epoch, 0xCAFEu);
    EXPECT_EQ(out.observations[i].odom_seq, out.increments[i].seq) << "features belong to their scan's increment";
    ASSERT_EQ(out.observations[i].n_features, 1);
    EXPECT_NEAR(out.observations[i].features[0].bearing, 0.0, 0.01);
    EXPECT_NEAR(out.observations[i].features[0].range, 3.0 + 0.05 + cfg.laser_mount.x, 0.1);  // to the pole's centre
  }
}

// mapping.feature_period_s: scans every 15 ms with the pole in each, a period of 50 ms.
// Features go out with scan 1 (15 ms), then with the first scan at least 50 ms later:
// scans 5, 9, 13, 17 (75, 135, 195, 255 ms); every scan still gives its increment.
TEST(RobotCore, FeaturesGoOutAtMostOncePerFeaturePeriod) {
  firmware::ExecutiveConfig cfg;
  cfg.feature_period = 50 * kMs;
  firmware::RobotCore core(cfg);
  Recorder out;
  for (int k = 1; k <= 20; ++k) {
    const Nanos t = k * 15 * kMs;
    core.on_wheels(wheels_at(cfg.geometry, 0.0, t));
    core.on_scan(scan_at(t, /*pole=*/true), t, out);
  }
  ASSERT_EQ(out.increments.size(), 20u);
  ASSERT_EQ(out.observations.size(), 5u);
  const int sent[] = {1, 5, 9, 13, 17};
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(out.observations[i].stamp, sent[i] * 15 * kMs);
    EXPECT_EQ(out.observations[i].seq, i + 1) << "feature seq counts messages sent, without gaps";
    EXPECT_EQ(out.observations[i].odom_seq, static_cast<std::uint32_t>(sent[i])) << "still linked to its scan's increment";
  }
}

// A period of exactly three scan intervals (45 ms at 15 ms) with stamps jittering ±1 ms
// (a scan may count up to 2 ms early)
// keeps every third scan; a due scan that sees no feature sends nothing and does not use
// up the period: the pole is hidden in scan 7, so features go out with 1, 4, 8, 11.
TEST(RobotCore, FeaturePeriodToleratesStampJitterAndWaitsForFeatures) {
  firmware::ExecutiveConfig cfg;
  cfg.feature_period = 45 * kMs;
  firmware::RobotCore core(cfg);
  Recorder out;
  std::vector<Nanos> stamps;
  for (int k = 1; k <= 12; ++k) {
    const Nanos t = k * 15 * kMs + (k % 2 == 0 ? 1 : -1) * kMs;
    stamps.push_back(t);
    core.on_wheels(wheels_at(cfg.geometry, 0.0, t));
    core.on_scan(scan_at(t, /*pole=*/k != 7), t, out);
  }
  const int sent[] = {1, 4, 8, 11};
  ASSERT_EQ(out.observations.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(out.observations[i].stamp, stamps[static_cast<std::size_t>(sent[i] - 1)]);
}

// Wheel samples every 10 ms at 1 m/s; a scan stamped at 50 ms sweeps 361 beams of
// 18.5 us, so its mid-sweep is 53.34 ms: its increment is the motion up to there, the
// 10 ms wheel sample that spans it split in proportion, and the rest waits for the next scan.
TEST(RobotCore, OdometryIsCutAtTheScansMidSweep) {
  firmware::ExecutiveConfig cfg;
  firmware::RobotCore core(cfg);
  Recorder out;
  const double v = 1.0;
  const Nanos half_sweep = static_cast<Nanos>(0.5 * (0.5 / 360.0 / 75.0) * 361 * 1e9);
  for (Nanos t = 0; t <= 60 * kMs; t += 10 * kMs) core.on_wheels(wheels_at(cfg.geometry, v, t));
  core.on_scan(scan_at(50 * kMs, false), 60 * kMs, out);
  for (Nanos t = 70 * kMs; t <= 90 * kMs; t += 10 * kMs) core.on_wheels(wheels_at(cfg.geometry, v, t));
  core.on_scan(scan_at(80 * kMs, false), 90 * kMs, out);
  ASSERT_EQ(out.increments.size(), 2u);
  const double count_m = cfg.geometry.wheel_radius_m / cfg.geometry.counts_per_wheel_rad();  // one count, in metres
  EXPECT_NEAR(out.increments[0].delta.x, v * nanos_to_seconds(50 * kMs + half_sweep), count_m);
  EXPECT_NEAR(out.increments[1].delta.x, v * 0.030, count_m);
  EXPECT_NEAR(out.increments[1].local_pose.x, v * nanos_to_seconds(80 * kMs + half_sweep), count_m);
  EXPECT_NEAR(core.local_pose().x, v * 0.090, count_m) << "the motion after the mid-sweep is kept, not lost";
  EXPECT_NEAR(out.increments[0].delta.y, 0.0, 1e-12);
  EXPECT_NEAR(out.increments[0].delta.theta, 0.0, 1e-12);
}

struct Counter : firmware::RobotOutputs {  // keeps nothing: allocates nothing
  std::uint64_t n = 0;
  void odometry(const msg::OdometryIncrement&) override { ++n; }
  void laser(const msg::LaserScan&) override { ++n; }
  void features(const msg::FeatureObservations&) override { ++n; }
};

// Issue 15: the laser protective field. The robot is asked for 0.6 m/s straight at a wall
// 3 m ahead and nothing else stops it: scans of the wall every 26.7 ms, wheel odometry of
// what it drives, every other input fresh. Returns the smallest gap left between the
// body (0.3 m) and the wall.
struct WallRun {
  double min_gap = 1e9, end_gap = 0;
  StopReason reason = StopReason::kNone;
  double end_v = 0;
  std::uint64_t allocations = 0;
  std::uint64_t stops = 0;  // safety stops over the run
};

WallRun drive_at_wall(bool field) {
  (void)logger();  // the process-wide logger allocates its ring once, as cairn-robot's start-up does
  firmware::ExecutiveConfig cfg;
  cfg.field.enabled = field;
  firmware::RobotCore core(cfg);
  Counter out;
  const double wall = 3.0;
  const canopen::DiffDriveGeometry& g = cfg.geometry;
  double x = 0;  // true position of the robot's centre
  WallRun run;
  lms::LmsScan scan = scan_at(0, false);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.005);  // the LMS2xx emulator's range noise
  Nanos next_scan = 0;
  const Nanos scan_period = 26'667'000;
  for (Nanos t = 0; t <= 12 * kNanosPerSecond; t += 10 * kMs) {
#ifdef CAIRN_COUNT_ALLOCS
    if (t == 1 * kNanosPerSecond) testing::start_counting_allocations();  // after start-up
#endif
    const double counts = x / g.wheel_radius_m * g.counts_per_wheel_rad();
    firmware::WheelReading w;
    w.left = static_cast<std::int32_t>(std::lround(counts));
    w.right = static_cast<std::int32_t>(std::lround(g.right_inverted ? -counts : counts));
    w.enabled = true;
    w.stamp = w.feedback_stamp = w.pass = t;
    core.on_wheels(w);
    if (t >= next_scan) {
      scan.stamp = t;
      for (std::size_t i = 0; i < scan.count; ++i) {
        const double c = std::cos(scan.angle(i));
        const double r = c > 0.05 ? (wall - x - cfg.laser_mount.x) / c + noise(rng) : 0.0;
        scan.range_mm[i] = r > 0 && r < 8.0 ? static_cast<std::uint16_t>(std::lround(r * 1000)) : 0;
      }
      core.on_scan(scan, t, out);
      next_scan += scan_period;
    }
    firmware::ControlInputs in;
    in.now = t;
    in.last_link = in.last_power = in.command_stamp = t;
    in.v = 0.6;
    core.control(in, 0.01);
    x += core.v() * 0.01;  // the wheels do what they are told
    run.min_gap = std::min(run.min_gap, wall - x - 0.3);
  }
#ifdef CAIRN_COUNT_ALLOCS  // the sanitizers' builds cannot link the counting allocator
  run.allocations = testing::stop_counting_allocations();
#endif
  run.end_gap = wall - x - 0.3;
  run.reason = core.stop();
  run.end_v = core.v();
  run.stops = core.stops();
  return run;
}

TEST(RobotCore, TheProtectiveFieldStopsTheRobotBeforeAWallWithoutAllocating) {
  const WallRun on = drive_at_wall(true);
  std::printf("protective field: closest %.3f m, stopped %.3f m from the wall\n", on.min_gap, on.end_gap);
  EXPECT_EQ(on.reason, StopReason::kProtectiveField);
  EXPECT_EQ(on.end_v, 0.0);
  // Stopped at the front margin (5 cm) plus the 2 cm side margin's widening in front, give
  // or take the 5 mm range noise; braked smoothly to it: one stop, at the end (the
  // scans' noise never trips a stop from speed).
  EXPECT_GE(on.min_gap, 0.06);
  EXPECT_LE(on.end_gap, 0.09);
  EXPECT_EQ(on.stops, 1u);
#ifdef CAIRN_COUNT_ALLOCS
  EXPECT_EQ(on.allocations, 0u);
#endif
  // Without it, nothing else stops the robot: it drives into the wall.
  const WallRun off = drive_at_wall(false);
  EXPECT_LT(off.min_gap, 0.0);
  EXPECT_EQ(off.reason, StopReason::kNone);
#ifdef CAIRN_COUNT_ALLOCS
  EXPECT_EQ(off.allocations, 0u);
#endif
}

}  // namespace
}  // namespace cairn
