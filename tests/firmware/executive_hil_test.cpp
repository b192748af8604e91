// One robot end to end on the HIL bench, in process: the executive drives the office
// world's corridor loop through its real drivers (LMS2xx over a pty, CiA 402 drives on a
// CAN bus, the power board over Modbus TCP). Checks: local drift vs ground truth <= 1 %
// of distance, features land on the world's poles, outputs in order, zero allocations
// on the RT and I/O threads in steady state, and each fault stops the robot with its
// reason and recovers.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "firmware/executive/devices.hpp"
#include "firmware/executive/executive.hpp"
#include "firmware/executive/path_follower.hpp"
#include "hil/bench/robot_bench.hpp"
#include "tests/support/pty_baud.hpp"
#include "tests/support/timing.hpp"
#ifndef CAIRN_SANITIZED
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn {
namespace {

std::atomic<std::uint64_t> g_allocations{0};
std::atomic<int> g_counted_threads{0};
void on_steady(const char*) {
#ifndef CAIRN_SANITIZED
  testing::start_counting_allocations();
#endif
}
void on_finished([[maybe_unused]] const char* name) {
#ifndef CAIRN_SANITIZED
  const std::uint64_t n = testing::stop_counting_allocations();
  if (n) std::printf("thread %s: %llu allocations after start-up\n", name, static_cast<unsigned long long>(n));
  g_allocations += n;
  ++g_counted_threads;
#endif
}

// The laser on a pty where it carries 500 kBd, else (under qemu-user) on TCP.
hil::RobotBenchConfig laser_link(hil::RobotBenchConfig bc) {
  std::string why;
  if (!testing::pty_carries_500k(&why)) {
    std::printf("laser over TCP: %s\n", why.c_str());
    bc.lms_tcp = true;
  }
  return bc;
}

struct Harness {
  hil::World world = hil::World::load(std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world");
  hil::RobotBench bench;
  firmware::ExecutiveConfig cfg;
  std::unique_ptr<firmware::Executive> exec;
  std::uint32_t last_odom_seq = 0, last_laser_seq = 0, last_feature_seq = 0;
  std::int64_t last_t1 = 0;
  std::uint64_t out_of_order = 0, odometry = 0, lasers = 0, landmark_obs = 0, landmark_near_pole = 0;
  Pose2 start;

  // realtime: ask for the production scheduling (SCHED_FIFO; granted to root, as in CI).
  explicit Harness(const hil::RobotBenchConfig& bc = {}, bool realtime = false)
      : bench(world, laser_link(bc)), start(bc.start) {
    bench.start();
    cfg.lms_uri = bench.lms_uri();
    cfg.can_uri = bench.can_uri();
    cfg.power_uri = bench.power_uri();
    cfg.laser_mount = bc.laser_mount;
    cfg.safety.max_v = 1.0;
    cfg.rt_loop = {};  // other tests run as an unprivileged user would
    cfg.io_threads = {};
    cfg.map_worker = {};
    if (realtime) {
      cfg.rt_loop = {80, -1, false};
      cfg.io_threads = {70, -1, false};
      cfg.map_worker = {50, -1, false};
    }
    auto& clock = MonotonicClock::instance();
    exec = std::make_unique<firmware::Executive>(cfg, clock, firmware::open_devices(cfg, clock, [] { return false; }),
                                                 firmware::ThreadHooks{on_steady, on_finished});
    exec->start();
  }
  ~Harness() {
    exec->stop();
    bench.stop();
  }
  // The non-RT side for one tick: drain outputs (checking order), follow, keep the link.
  void tick(firmware::PathFollower* follower, bool link = true) {
    const Nanos now = MonotonicClock::instance().now();
    msg::OdometryIncrement inc;
    while (exec->pop_odometry(&inc)) {
      if (inc.seq != last_odom_seq + 1 || inc.t1 < last_t1) ++out_of_order;
      last_odom_seq = inc.seq;
      last_t1 = inc.t1;
      ++odometry;
    }
    static msg::LaserScan scan;
    while (exec->pop_laser(&scan)) {
      if (scan.seq != last_laser_seq + 1) ++out_of_order;
      last_laser_seq = scan.seq;
      ++lasers;
    }
    static msg::FeatureObservations f;
    while (exec->pop_features(&f)) {
      if (f.seq != last_feature_seq + 1) ++out_of_order;
      last_feature_seq = f.seq;
      const Pose2 local{f.local_pose.x, f.local_pose.y, f.local_pose.theta};
      for (int i = 0; i < f.n_features; ++i) {
        if (f.features[i].kind != msg::FeatureKind::kLandmark) continue;
        const Vec2 p = transform_point(start, point_from_observation(local, {f.features[i].range, f.features[i].bearing}));
        double best = 1e9;
        for (const Vec2& pole : world.poles()) best = std::min(best, (pole - p).norm());
        ++landmark_obs;
        if (best < 0.15) ++landmark_near_pole;
      }
    }
    if (link) exec->note_link(now);
    static Nanos next_print = 0;
    if (std::getenv("CAIRN_TEST_VERBOSE") && now > next_print) {
      next_print = now + kNanosPerSecond;
      const auto s = exec->rt_snapshot();
      const Pose2 t = truth_local();
      std::printf("local %.2f %.2f %.2f truth %.2f %.2f %.2f stop %s v %.2f w %.2f scans %llu matched %llu\n", s.local_pose.x,
                  s.local_pose.y, s.local_pose.theta, t.x, t.y, t.theta, firmware::stop_reason_text(s.stop), s.v, s.w,
                  static_cast<unsigned long long>(s.scans), static_cast<unsigned long long>(s.matched));
      std::fflush(stdout);
    }
    double v = 0, w = 0;
    if (follower) follower->command(exec->rt_snapshot().local_pose, &v, &w);
    exec->set_velocity(v, w, now);
  }
  template <typename F>
  double run_until(F done, double timeout_s, firmware::PathFollower* follower = nullptr, bool link = true) {
    auto& clock = MonotonicClock::instance();
    const Nanos t0 = clock.now(), end = t0 + seconds_to_nanos(timeout_s);
    while (clock.now() < end) {
      tick(follower, link);
      if (done()) return nanos_to_seconds(clock.now() - t0);
      clock.sleep_until(clock.now() + 20 * kNanosPerMilli);
    }
    return -1;
  }
  Pose2 truth_local() const { return between(start, bench.truth().pose); }
};

TEST(ExecutiveHil, CorridorLoopDriftFeaturesOrderAndNoAllocations) {
  g_allocations = 0;
  g_counted_threads = 0;
  Pose2 end_local, end_truth;
  double odometer = 0;
  [[maybe_unused]] bool rt_granted = false;  // read only in unsanitized builds
  firmware::RtSnapshot snap;
  {
    hil::RobotBenchConfig bc;
    bc.start = {5.0, 10.0, 0.0};
    Harness h(bc, /*realtime=*/true);
    ASSERT_GT(h.run_until([&] { return h.exec->rt_snapshot().stop == firmware::StopReason::kNone; }, 10.0), 0)
        << "never ready: stop reason " << firmware::stop_reason_text(h.exec->rt_snapshot().stop);
    // Written by the RT thread before its first snapshot, which the line above has read.
    rt_granted = h.exec->rt_reports()[3].find("SCHED_FIFO 80") != std::string::npos;
    std::printf("%s\n", h.exec->rt_reports()[3].c_str());
    // Along the corridor's centre line (its poles stand 0.5-0.8 m off it): east to the end,
    // back west, east again (~51 m). Waypoints in the world, followed in the local frame.
    const std::vector<Vec2> world_path = {{22, 10}, {4.8, 10}, {21.5, 10}};
    std::vector<Vec2> local_path;
    for (const Vec2& p : world_path) local_path.push_back(inverse_transform_point(h.start, p));
    firmware::FollowerConfig fc;
    fc.speed = 1.0;
    // This loop steers from the test thread every 20 ms. Under qemu or a sanitizer that loop
    // runs several times slower, and pure pursuit at 1 m/s with the default 0.6 m lookahead
    // then oscillates after the turn-arounds until the robot hits a pole. Steering is not
    // what this test checks, so it looks further ahead there.
    if (testing::timing_slack() > 1.0) fc.lookahead = 1.2;
    firmware::PathFollower follower(local_path, fc);
    ASSERT_GT(h.run_until([&] { return follower.done(); }, 150.0, &follower), 0) << "path not finished";
    h.run_until([] { return false; }, 0.5);  // stand still, drain
    end_local = h.exec->rt_snapshot().local_pose;
    end_truth = h.truth_local();
    odometer = h.bench.truth().odometer;
    snap = h.exec->rt_snapshot();
    EXPECT_EQ(h.out_of_order, 0u);
    EXPECT_GT(h.odometry, 1000u);
    EXPECT_GT(h.lasers, 100u);
    EXPECT_GT(h.landmark_obs, 200u);
    // A landmark lands within 15 cm of its pole only if the scan's stamp (and so the pose it is
    // placed from) is close to when the laser took it. Natively that lag is well under a
    // millisecond; under qemu or a sanitizer the I/O thread wakes tens of ms late (p99 period
    // ~70 ms at 1 m/s is ~7 cm), so the bound there is looser.
    const double near_share = testing::timing_slack() > 1.0 ? 0.90 : 0.95;
    EXPECT_GT(static_cast<double>(h.landmark_near_pole), near_share * static_cast<double>(h.landmark_obs));
    std::printf("landmark observations %llu, %.1f %% within 15 cm of a pole\n",
                static_cast<unsigned long long>(h.landmark_obs), 100.0 * static_cast<double>(h.landmark_near_pole) / static_cast<double>(h.landmark_obs));
  }
  const double drift = std::hypot(end_local.x - end_truth.x, end_local.y - end_truth.y);
  std::printf("travelled %.1f m; local pose error %.3f m = %.2f %% (heading %.2f deg); scans %llu, matched %llu\n",
              odometer, drift, 100 * drift / odometer, std::abs(normalize_angle(end_local.theta - end_truth.theta)) * 57.3,
              static_cast<unsigned long long>(snap.scans), static_cast<unsigned long long>(snap.matched));
  std::printf("RT loop: period mean %.1f us, p99 %.1f us, max jitter %.1f us, %llu cycles, %llu deadline misses\n",
              static_cast<double>(snap.period_mean_us), static_cast<double>(snap.period_p99_us), static_cast<double>(snap.jitter_max_us), static_cast<unsigned long long>(snap.cycles),
              static_cast<unsigned long long>(snap.misses));
  EXPECT_GT(odometer, 45.0);
  EXPECT_LT(drift, 0.01 * odometer);
  EXPECT_GT(snap.matched, snap.scans * 9 / 10);
  EXPECT_EQ(snap.overflows, 0u);
#ifndef CAIRN_SANITIZED
  // With the production scheduling no control cycle may finish a whole period late. Not
  // under qemu-user (timing slack > 1), where the emulated CPU is several times slower.
  if (rt_granted && testing::timing_slack() == 1.0) {
    EXPECT_EQ(snap.misses, 0u) << "deadline misses with SCHED_FIFO";
  }
  EXPECT_EQ(g_counted_threads.load(), 5);
  EXPECT_EQ(g_allocations.load(), 0u) << "heap allocations on the RT and I/O threads after start-up";
#endif
}

TEST(ExecutiveHil, EveryFaultStopsWithItsReasonAndRecovers) {
  Harness h;
  using firmware::StopReason;
  auto reason = [&] { return h.exec->rt_snapshot().stop; };
  ASSERT_GT(h.run_until([&] { return reason() == StopReason::kNone; }, 10.0), 0);
  firmware::FollowerConfig fc;
  fc.speed = 0.3;
  firmware::PathFollower follower({{15.0, 0.0}}, fc);
  auto moving = [&] { return std::abs(h.exec->rt_snapshot().v) > 0.05; };
  ASSERT_GT(h.run_until(moving, 3.0, &follower), 0);

  // E-stop: the drives are disabled within one control period (10 ms) + the e-stop poll (5 ms).
  h.bench.power().press_estop(true);
  const double t_estop = h.run_until([&] {
    return h.bench.drive(0).with_node([](hil::DriveNode& n) { return n.state(); }) != cia402::State::kOperationEnabled;
  }, 1.0, &follower);
  EXPECT_GT(t_estop, 0);
  EXPECT_EQ(h.run_until([&] { return reason() == StopReason::kEstop; }, 1.0, &follower) >= 0, true);
  h.bench.power().press_estop(false);
  EXPECT_GT(h.run_until(moving, 5.0, &follower), 0) << firmware::stop_reason_text(reason());

  // Laser unplugged: stop (laser silent); plugged back: the driver reconnects, we move.
  h.bench.lms().unplug(true);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kLaserLost; }, 2.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().v, 0.0);
  h.bench.lms().unplug(false);
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());

  // A drive stops answering (heartbeat loss): zero velocity, drives not ready; then back.
  h.bench.drive(1).with_node([](hil::DriveNode& n) { return (n.set_silent(true), 0); });
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kDrivesNotReady; }, 2.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().v, 0.0);
  h.bench.drive(1).with_node([](hil::DriveNode& n) { return (n.set_silent(false), 0); });
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());

  // Base-station link lost: stop; back: move.
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kLinkLost; }, 4.0, &follower, false), 0);
  EXPECT_GT(h.run_until(moving, 3.0, &follower), 0);

  // A NaN velocity command is never applied.
  h.exec->set_velocity(std::nan(""), 0.0, MonotonicClock::instance().now());
  EXPECT_TRUE(std::isfinite(h.exec->rt_snapshot().v));
  EXPECT_EQ(h.out_of_order, 0u);
  EXPECT_GE(h.exec->rt_snapshot().stops, 4u);
}

}  // namespace
}  // namespace cairn
