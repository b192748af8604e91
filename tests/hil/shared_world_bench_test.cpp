// The HIL bench's shared world (cairn-hil robots --shared-world) with real threads: a
// robot's emulated laser, read by the production driver, sees another robot's body where
// FleetBodies has it; and two physics threads pushing bodies at each other never commit
// overlapping poses (run it under TSan: the bodies and the sensor world are shared).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <thread>

#include "drivers/sick/lms_driver.hpp"
#include "hil/bench/robot_bench.hpp"
#include "hil/world/fleet_bodies.hpp"

namespace cairn::hil {
namespace {

using namespace std::chrono_literals;

struct FirstScan : lms::ScanSink {
  std::mutex m;
  std::optional<lms::LmsScan> scan;
  void on_scan(const lms::LmsScan& s) override {
    std::lock_guard l(m);
    if (!scan) scan = s;
  }
};

/// The range (mm) straight ahead in the first scan the driver reads from `uri` (TCP,
/// 500 kBd), or -1 when none arrives in 10 s.
int range_ahead_mm(const std::string& uri) {
  std::string err;
  auto stream = serial::open_stream(uri, 500000, &err);
  if (!stream) throw std::runtime_error(err);
  FirstScan sink;
  lms::LmsDriverConfig dc;
  dc.target_baud = 500000;
  dc.resolution_centideg = 50;
  lms::LmsDriver driver(stream.get(), &MonotonicClock::instance(), dc, &sink);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < deadline) {
    driver.step();  // waits for bytes at most io_slice
    std::lock_guard l(sink.m);
    if (sink.scan) {
      const lms::LmsScan& s = *sink.scan;
      const auto ahead = static_cast<std::size_t>(std::lround(-s.angle_min / s.angle_increment));
      return ahead < s.count ? s.range_mm[ahead] : -1;
    }
  }
  return -1;
}

RobotBenchConfig bench_config(int id, const Pose2& start) {
  RobotBenchConfig c;
  c.robot_id = id;
  c.start = start;
  c.lms_tcp = true;
  c.lms.boot_time_s = 0.1;
  return c;
}

TEST(SharedWorldBench, ALaserSeesAnotherRobotsBody) {
  const World world = World::parse("box 0 0 20 10\n", "hall");
  const Pose2 start1{5, 5, 0}, start2{7, 5, M_PI};
  // Robot 2 is out of robot 1's view when robot 1's bench is built and comes into it
  // after: the laser must see it where it is at the scan, not where it was.
  FleetBodies bodies({{1, start1, 0.3}, {2, {7, 8, M_PI}, 0.3}});
  RobotBench r1(world, bench_config(1, start1), &bodies);
  ASSERT_EQ(bodies.try_move(2, start2), 0);
  RobotBench r2(world, bench_config(2, start2), &bodies);
  RobotBench alone(world, bench_config(3, start1));  // the same place, its own world
  r1.start();
  r2.start();
  alone.start();
  // The laser sits 0.2 m ahead of the body's centre: robot 2's surface is 1.5 m ahead of
  // it; alone, the far wall at x = 20 is 14.8 m ahead.
  EXPECT_NEAR(range_ahead_mm(r1.lms_uri()), 1500, 30);
  EXPECT_NEAR(range_ahead_mm(r2.lms_uri()), 1500, 30);
  EXPECT_NEAR(range_ahead_mm(alone.lms_uri()), 14800, 30);
  EXPECT_EQ(r1.truth().robot_contacts, 0u);  // standing still touches nothing
}

// Two physics threads drive bodies head-on, as two benches' threads do: each checks every
// pose it committed against the other's current one.
TEST(SharedWorldBench, ConcurrentMovesNeverOverlap) {
  const World world = World::parse("box 0 0 20 10\n", "hall");
  FleetBodies bodies({{1, {5, 5, 0}, 0.3}, {2, {8, 5, M_PI}, 0.3}});
  std::atomic<bool> go{false};
  std::atomic<double> closest{1e9};
  auto run = [&](int id, const Pose2& start) {
    World own = world;
    canopen::DiffDriveGeometry g;
    DiffRobot robot(id, g, start, 0.3, &own);
    robot.share_bodies(&bodies);
    const canopen::WheelCommand ahead = canopen::wheel_command(g, 0.5, 0.0);
    while (!go.load()) std::this_thread::yield();
    Body other[1];
    for (int k = 0; k < 20000; ++k) {
      robot.step(ahead.left, ahead.right, 0.001);  // 0.5 mm a step: 20 m, far past touching
      bodies.snapshot_others(id, other);
      const double d = (robot.pose().translation() - other[0].pose.translation()).norm();
      for (double c = closest.load(); d < c && !closest.compare_exchange_weak(c, d);) {
      }
    }
    return robot.robot_contacts();
  };
  std::uint64_t contacts1 = 0, contacts2 = 0;
  std::thread t1([&] { contacts1 = run(1, {5, 5, 0}); });
  std::thread t2([&] { contacts2 = run(2, {8, 5, M_PI}); });
  go = true;
  t1.join();
  t2.join();
  EXPECT_GE(closest.load(), 0.6);
  EXPECT_LT(closest.load(), 0.601);  // they did meet
  EXPECT_GT(contacts1 + contacts2, 0u);
  EXPECT_EQ(bodies.contacts(1, 2), 1u);
}

}  // namespace
}  // namespace cairn::hil
