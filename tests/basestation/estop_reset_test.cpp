// `cairn-base --reset-estop ID` against fake robots on DDS (loopback profile, own domain):
// each fake robot is its own participant with the robot's RobotStatus writer and
// SafetyReset reader (the QoS of firmware/robot_bridge.cpp), and answers a reset for its
// id as the robot does (stop reason 8 -> 2).
//
// Only what needs DDS is here: the reset crosses DDS to the named robot's reader and its
// status brings the confirmation back. The exchange's logic (resends, timeouts, refusals,
// an absent robot) is estop_reset_machine_test's, on simulated time.
//
// The test is the demo's failure: with robot 1 already on the domain, the old tool
// waited for "one matched reader", wrote one volatile sample and exited with "sent";
// robot 2, whose reader matched later, never saw it and stayed latched.
#include "basestation/estop_reset.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "common/dds/profile.hpp"
#include "common/dds/qos.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {
namespace {

constexpr std::uint32_t kDomain = 113;  // this test's own domain

class FakeRobot {
 public:
  FakeRobot(std::uint16_t id, StopReason reason, Nanos status_period = 50 * kNanosPerMilli)
      : id_(id), reason_(static_cast<std::uint8_t>(reason)), period_(status_period) {
    thread_ = std::thread([this] { run(); });
  }
  ~FakeRobot() {
    stop_ = true;
    thread_.join();
  }
  int resets() const { return resets_; }
  StopReason reason() const { return static_cast<StopReason>(reason_.load()); }

 private:
  void run() {
    dds::Participant pp(dds::loopback_profile(kDomain));
    dds::Topic<cairn_RobotStatus> st(pp);
    dds::Writer<cairn_RobotStatus> status(pp, st, dds::state_qos());
    dds::Topic<cairn_SafetyReset> rt(pp);
    dds::Reader<cairn_SafetyReset> resets(pp, rt, dds::state_qos(4));
    std::uint32_t seq = 0;
    while (!stop_) {
      resets.take([&](const cairn_SafetyReset& r, const dds_sample_info_t&) {
        if (r.robot_id != id_) return;
        ++resets_;
        if (reason_ == static_cast<std::uint8_t>(StopReason::kResetRequired)) {
          reason_ = static_cast<std::uint8_t>(StopReason::kDrivesNotReady);
        }
      });
      cairn_RobotStatus s{};
      s.robot_id = id_;
      s.seq = ++seq;
      s.stop_reason = reason_;
      dds::set_text(s.stop_text, stop_reason_text(static_cast<StopReason>(reason_.load())));
      status.write(s);
      resets.wait(period_);
    }
  }

  std::uint16_t id_;
  std::atomic<std::uint8_t> reason_;
  Nanos period_;
  std::atomic<int> resets_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

EstopResetRequest request(std::uint16_t robot) {
  EstopResetRequest r;
  r.robot = robot;
  r.issued_by = "estop_reset_test";
  r.timeout = 10 * kNanosPerSecond;
  r.confirm_wait = 500 * kNanosPerMilli;
  return r;
}

TEST(EstopReset, ReachesTheNamedRobotWhenAnotherRobotMatchedFirst) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot one(1, StopReason::kResetRequired);
  std::unique_ptr<FakeRobot> two;
  // Robot 2 joins while the reset is already under way.
  std::thread late([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    two = std::make_unique<FakeRobot>(2, StopReason::kResetRequired);
  });
  const EstopResetResult r = reset_estop(base, request(2));
  late.join();
  EXPECT_EQ(r.outcome, EstopResetOutcome::kConfirmed) << r.message;
  EXPECT_GE(r.sent, 1);
  EXPECT_GE(two->resets(), 1);
  EXPECT_EQ(two->reason(), StopReason::kDrivesNotReady);
  // Robot 1 saw our samples (it reads the topic) but none named it, and it stays latched.
  EXPECT_EQ(one.resets(), 0);
  EXPECT_EQ(one.reason(), StopReason::kResetRequired);
  EXPECT_NE(r.message.find("reset accepted"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace cairn::base
