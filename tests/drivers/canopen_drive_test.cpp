// The CANopen master against two emulated CiA 402 drives on the user-space CAN bus, in
// real time: the transport (sockets, the hub's bus-off and error frames, threads) with
// boot-up, velocity, bus-off and garbage. The master's timing logic (heartbeat consumer
// bound, fault reset, disable_all, SYNC-loss stop) is asserted exactly on simulated time
// in canopen_sim_test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>

#include "drivers/can/can_hub.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "hil/cia402/drive_runner.hpp"
#include "tests/support/timing.hpp"

namespace cairn {
namespace {

using canopen::NodePhase;
constexpr std::uint16_t kMasterSender = 100;

class Bench {
 public:
  explicit Bench(bool halt_quirk = false) : hub_("/tmp/cairn-canopen-test-" + std::to_string(getpid()) + "-" + std::to_string(counter_++)) {
    for (int node = 1; node <= 2; ++node) {
      const auto id = static_cast<std::uint8_t>(node);
      std::string err;
      auto port = can::UcanPort::open(hub_.path(), id, false, &err);
      hil::DriveConfig c;
      c.node = id;
      c.reject_halt = halt_quirk && id == 2;
      drives_.push_back(std::make_unique<hil::DriveRunner>(std::move(port), c));
      drives_.back()->start();
    }
    std::string err;
    port_ = can::UcanPort::open(hub_.path(), kMasterSender, false, &err);
    for (int i = 0; i < 200 && hub_.ports() < 3; ++i) usleep(1000);
    master_ = std::make_unique<canopen::DriveMaster>(port_.get(), &MonotonicClock::instance(), mc_);
    running_ = true;
    thread_ = std::thread([this] {
      while (running_) {
        std::lock_guard l(mutex_);
        master_->step();
      }
    });
  }
  ~Bench() {
    running_ = false;
    thread_.join();
    for (auto& d : drives_) d->stop();
  }
  template <typename F>
  auto master(F&& f) {
    std::lock_guard l(mutex_);
    return f(*master_);
  }
  /// Seconds until pred() holds, or -1.
  template <typename P>
  double until(P pred, double timeout_s) {
    const Nanos t0 = MonotonicClock::instance().now();
    while (MonotonicClock::instance().now() - t0 < seconds_to_nanos(timeout_s)) {
      if (pred()) return nanos_to_seconds(MonotonicClock::instance().now() - t0);
      usleep(500);
    }
    return -1;
  }
  bool enabled() {
    return master([](canopen::DriveMaster& m) { return m.all_enabled(); });
  }
  std::string events() {
    return master([](canopen::DriveMaster& m) {
      std::string s;
      for (std::size_t i = 0; i < m.event_count(); ++i) {
        const auto& e = m.event(i);
        s += "node " + std::to_string(e.node) + " -> " + canopen::phase_name(e.to) + ": " + e.reason.data() + "\n";
      }
      return s;
    });
  }
  static inline int counter_ = 0;
  const canopen::MasterConfig mc_{};  // the shipped defaults: heartbeat 50 ms, consumer timeout 110 ms
  can::Hub hub_;
  std::vector<std::unique_ptr<hil::DriveRunner>> drives_;
  std::unique_ptr<can::Port> port_;
  std::unique_ptr<canopen::DriveMaster> master_;
  std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

TEST(CanopenDrives, BootUpToOperationEnabledAndVelocityReachesTheWheels) {
  Bench b(/*halt_quirk=*/true);  // drive 2 faults on HALT: the master must never send it
  const double t = b.until([&] { return b.enabled(); }, 5.0);
  ASSERT_GT(t, 0) << b.events();
  std::printf("boot-up to operation enabled (both drives): %.3f s\n", t);
  const std::int32_t cmd[] = {50000, -30000};
  b.master([&](canopen::DriveMaster& m) { return (m.command(cmd), 0); });
  const auto updates0 = b.master([](canopen::DriveMaster& m) { return m.feedback(0).updates; });
  usleep(1000000);
  const auto updates1 = b.master([](canopen::DriveMaster& m) { return m.feedback(0).updates; });
  EXPECT_NEAR(static_cast<double>(updates1 - updates0), 100.0, 15.0) << "feedback at the 100 Hz SYNC rate";
  EXPECT_NEAR(b.drives_[0]->with_node([](hil::DriveNode& n) { return n.velocity(); }), 50000, 1);
  EXPECT_NEAR(b.drives_[1]->with_node([](hil::DriveNode& n) { return n.velocity(); }), -30000, 1);
  const auto fb = b.master([](canopen::DriveMaster& m) { return m.feedback(0); });
  EXPECT_NEAR(fb.velocity, 50000, 1);
  EXPECT_GT(fb.position, 30000);  // ~0.9 s at speed
  EXPECT_EQ(b.master([](canopen::DriveMaster& m) { return m.drive_state(1); }), cia402::State::kOperationEnabled);
}

TEST(CanopenDrives, BusOffIsRecoveredAndTheDrivesStopMeanwhile) {
  Bench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  const std::int32_t cmd[] = {30000, 30000};
  b.master([&](canopen::DriveMaster& m) { return (m.command(cmd), 0); });
  ASSERT_GT(b.until([&] { return b.drives_[0]->with_node([](hil::DriveNode& n) { return n.velocity(); }) > 29000; }, 1.0), 0);
  b.hub_.inject_bus_off(kMasterSender, 500 * kNanosPerMilli);  // the fault persists for 0.5 s
  // The drives see no SYNC and stop on their own (sync loss); the master retries with back-off.
  const double stopped = b.until([&] { return b.drives_[0]->with_node([](hil::DriveNode& n) { return n.velocity(); }) == 0.0; }, 2.0);
  EXPECT_GT(stopped, 0) << b.events();
  EXPECT_FALSE(b.enabled());
  const double t = b.until([&] { return b.enabled(); }, 5.0);
  ASSERT_GT(t, 0) << b.events();
  std::printf("bus-off held 500 ms: drives stopped after %.0f ms; enabled again %.3f s later\n", stopped * 1000, t);
  EXPECT_GT(stopped + t, 0.5);  // not before the fault cleared
  EXPECT_GE(b.port_->stats().bus_off, 1u);
}

}  // namespace
}  // namespace cairn

#include "drivers/canopen/diff_drive.hpp"
#include "hil/robot/diff_robot.hpp"

namespace cairn {
namespace {

TEST(CanopenDrives, GarbageFramesAreSurvived) {
  Bench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  for (auto& d : b.drives_) d->with_node([](hil::DriveNode& n) { return (n.inject_garbage(300, 7), 0); });
  usleep(300000);
  EXPECT_TRUE(b.enabled()) << b.events();
  const auto fb = b.master([](canopen::DriveMaster& m) { return m.feedback(0); });
  EXPECT_EQ(cia402::decode(fb.statusword), cia402::State::kOperationEnabled);
}

TEST(CanopenDrives, TwoDrivesMoveASimulatedRobotInTheWorld) {
  Bench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  hil::World world = hil::World::parse("box 0 0 20 20\n", "hall");
  canopen::DiffDriveGeometry g;
  hil::DiffRobot robot(1, g, {5, 5, 0}, 0.3, &world);
  // Drives at (v, w) until `done` holds or `timeout` s pass: the wall clock's pace is not
  // the subject here (simulated-time tests own the timing), the wheels are. Returns the
  // drives' velocities at the end, which must equal the command once the ramp is over.
  struct Wheels {
    double left, right;
    double max_step_s;  // the longest step of the loop: how far past the target it can end
  };
  auto drive_until = [&](double v, double w, auto done, double timeout) {
    const canopen::WheelCommand c = canopen::wheel_command(g, v, w);
    const std::int32_t cmd[] = {c.left, c.right};
    b.master([&](canopen::DriveMaster& m) { return (m.command(cmd), 0); });
    const Nanos end = MonotonicClock::instance().now() + seconds_to_nanos(timeout);
    Nanos last = MonotonicClock::instance().now();
    Wheels wheels{0, 0, 0};
    while (!done() && MonotonicClock::instance().now() < end) {
      usleep(5000);
      const Nanos now = MonotonicClock::instance().now();
      wheels.left = b.drives_[0]->with_node([](hil::DriveNode& n) { return n.velocity(); });
      wheels.right = b.drives_[1]->with_node([](hil::DriveNode& n) { return n.velocity(); });
      robot.step(wheels.left, wheels.right, nanos_to_seconds(now - last));
      wheels.max_step_s = std::max(wheels.max_step_s, nanos_to_seconds(now - last));
      last = now;
    }
    EXPECT_TRUE(done()) << "not reached in " << timeout << " s; pose (" << robot.pose().x << ", " << robot.pose().y << ", "
                        << robot.pose().theta << ")";
    EXPECT_NEAR(wheels.left, c.left, 0.02 * std::abs(c.left) + 1) << "left drive's steady velocity";
    EXPECT_NEAR(wheels.right, c.right, 0.02 * std::abs(c.right) + 1) << "right drive's steady velocity";
    return wheels;
  };
  // The loop stops at the first step past the target: at most one step (0.5 m/s or rad/s) over.
  const Wheels straight = drive_until(0.5, 0.0, [&] { return robot.pose().x >= 6.0; }, 5.0);  // 1 m straight ahead
  EXPECT_LE(robot.pose().x, 6.0 + 0.5 * straight.max_step_s + 1e-3);
  EXPECT_NEAR(robot.pose().y, 5.0, 0.01);  // straight: equal wheels
  EXPECT_NEAR(robot.pose().theta, 0.0, 0.01);
  // Turning on the spot, the robot moves only until the new command reaches the drives (the
  // next SYNC's RPDO: 10 ms, allowed 100 ms under load) and while its wheels ramp down from
  // 0.5 m/s at the profile acceleration (0x6083 = 400 000 increments/s²): v²/2a = 4.1 cm.
  const double a = 400000.0 * g.wheel_radius_m / g.counts_per_wheel_rad();
  const double ramp_m = 0.5 * 0.5 / (2 * a) + 0.5 * 0.1;
  const Pose2 before_turn = robot.pose();
  const Wheels turn = drive_until(0.0, 0.5, [&] { return robot.pose().theta >= 1.0; }, 5.0);
  EXPECT_LE(robot.pose().theta, 1.0 + 0.5 * turn.max_step_s + 1e-3);
  EXPECT_LT(std::hypot(robot.pose().x - before_turn.x, robot.pose().y - before_turn.y), ramp_m + 0.01);
  auto wheel_speed = [&](int k) { return b.drives_[k]->with_node([](hil::DriveNode& n) { return n.velocity(); }); };
  drive_until(0.0, 0.0, [&] { return wheel_speed(0) == 0.0 && wheel_speed(1) == 0.0; }, 1.0);
  std::printf("robot after 1 m straight and a 1 rad turn: (%.3f, %.3f, %.3f)\n", robot.pose().x, robot.pose().y,
              robot.pose().theta);
}

}  // namespace
}  // namespace cairn
