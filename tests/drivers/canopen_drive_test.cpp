// The CANopen master against two emulated CiA 402 drives on the user-space CAN bus, in
// real time: the transport only (sockets, the hub's bus-off and error frames, threads)
// with boot-up, velocity and bus-off. The master's logic (feedback at the SYNC rate,
// heartbeat consumer bound, fault reset, disable_all, SYNC-loss stop, garbage frames, the
// drives moving a simulated robot) is asserted exactly on simulated time in canopen_sim_test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <mutex>
#include <thread>

#include "drivers/can/can_hub.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "hil/cia402/drive_runner.hpp"

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
  // Until the TPDOs over the hub report the commanded velocity (the feedback rate is
  // CanopenSim's, on simulated time); the timeout is a hang guard.
  ASSERT_GT(b.until([&] { return b.master([](canopen::DriveMaster& m) { return m.feedback(0).velocity >= 50000 - 1; }); }, 5.0), 0)
      << b.events();
  EXPECT_NEAR(b.drives_[0]->with_node([](hil::DriveNode& n) { return n.velocity(); }), 50000, 1);
  EXPECT_NEAR(b.drives_[1]->with_node([](hil::DriveNode& n) { return n.velocity(); }), -30000, 1);
  const auto fb = b.master([](canopen::DriveMaster& m) { return m.feedback(0); });
  EXPECT_NEAR(fb.velocity, 50000, 1);
  EXPECT_GT(fb.position, 2000);  // TPDO2 too: the ramp alone is 50000² / (2 × 400000) = 3125, less a SYNC of lag
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
