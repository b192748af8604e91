// `cairn-base --reset-estop ID` against fake robots on DDS (loopback profile, own domain):
// each fake robot is its own participant with the robot's RobotStatus writer and
// SafetyReset reader (the QoS of firmware/robot_bridge.cpp), and answers a reset for its
// id as the robot does (stop reason 8 -> 2) or not at all.
//
// The first test is the demo's failure: with robot 1 already on the domain, the old tool
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
  FakeRobot(std::uint16_t id, StopReason reason, bool accepts, Nanos status_period = 50 * kNanosPerMilli,
            std::uint32_t remote_stops = 0)
      : id_(id), reason_(static_cast<std::uint8_t>(reason)), accepts_(accepts), period_(status_period), remote_stops_(remote_stops) {
    thread_ = std::thread([this] { run(); });
  }
  ~FakeRobot() {
    stop_ = true;
    thread_.join();
  }
  int resets() const { return resets_; }
  std::uint32_t last_stops_seen() const { return last_stops_seen_; }
  int foreign_resets() const { return foreign_; }
  StopReason reason() const { return static_cast<StopReason>(reason_.load()); }

 private:
  void run() {
    dds::Participant pp(dds::loopback_profile(kDomain));
    dds::Topic<cairn_RobotStatus> st(pp);
    dds::Writer<cairn_RobotStatus> status(pp, st, dds::state_qos(), id_);
    dds::Topic<cairn_SafetyReset> rt(pp);
    dds::Reader<cairn_SafetyReset> resets(pp, rt, dds::state_qos(4));
    std::uint32_t seq = 0;
    while (!stop_) {
      resets.take([&](const cairn_SafetyReset& r, const dds_sample_info_t&) {
        if (r.robot_id != id_) {
          ++foreign_;
          return;
        }
        ++resets_;
        last_stops_seen_ = r.remote_stops_seen;
        if (accepts_ && reason_ == static_cast<std::uint8_t>(StopReason::kResetRequired)) {
          reason_ = static_cast<std::uint8_t>(StopReason::kDrivesNotReady);
        }
      });
      cairn_RobotStatus s{};
      s.robot_id = id_;
      s.seq = ++seq;
      s.stop_reason = reason_;
      s.remote_stops = remote_stops_;
      dds::set_text(s.stop_text, stop_reason_text(static_cast<StopReason>(reason_.load())));
      status.write(s);
      resets.wait(period_);
    }
  }

  std::uint16_t id_;
  std::atomic<std::uint8_t> reason_;
  bool accepts_;
  Nanos period_;
  std::uint32_t remote_stops_;
  std::atomic<std::uint32_t> last_stops_seen_{0};
  std::atomic<int> resets_{0}, foreign_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

EstopResetRequest request(std::uint16_t robot, Nanos timeout = 10 * kNanosPerSecond) {
  EstopResetRequest r;
  r.robot = robot;
  r.issued_by = "estop_reset_test";
  r.timeout = timeout;
  r.confirm_wait = 500 * kNanosPerMilli;
  return r;
}

TEST(EstopReset, ReachesTheNamedRobotWhenAnotherRobotMatchedFirst) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot one(1, StopReason::kResetRequired, true);
  std::unique_ptr<FakeRobot> two;
  // Robot 2 joins while the reset is already under way.
  std::thread late([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    two = std::make_unique<FakeRobot>(2, StopReason::kResetRequired, true);
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

TEST(EstopReset, ARobotThatStaysLatchedIsReportedUnconfirmedAfterResending) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot stubborn(3, StopReason::kResetRequired, false);
  const EstopResetResult r = reset_estop(base, request(3, 3 * kNanosPerSecond));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kUnconfirmed) << r.message;
  EXPECT_FALSE(r.ok());
  EXPECT_GE(r.sent, 2);  // 3 s at one try per 0.5 s
  // Every sample reached it (the last may still be on its way to the fake robot's take).
  for (int k = 0; k < 100 && stubborn.resets() < r.sent; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(stubborn.resets(), r.sent);
  EXPECT_NE(r.message.find("still says stop reason 8"), std::string::npos) << r.message;
}

// Every reset names the robot's remote-stop count its exchange saw first (RobotStatus
// .remote_stops): a robot latched again by a later remote e-stop refuses the exchange's resends.
TEST(EstopReset, AResetCarriesTheRemoteStopCountItSaw) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot stopped(9, StopReason::kResetRequired, true, 50 * kNanosPerMilli, 3);
  const EstopResetResult r = reset_estop(base, request(9));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kConfirmed) << r.message;
  EXPECT_EQ(stopped.last_stops_seen(), 3u);
}

// E-STOP ALL ends the exchanges under way: nothing of theirs goes out after the stop.
TEST(EstopReset, CancelAllEndsEveryExchangeAtOnce) {
  dds::Participant base(dds::loopback_profile(kDomain));
  EstopResetNode node(base);
  std::string why;
  ASSERT_TRUE(node.start(41, request(10), 0, &why)) << why;
  ASSERT_TRUE(node.start(42, request(11), 0, &why)) << why;
  EXPECT_FALSE(node.start(43, request(11), 0, &why));
  EXPECT_EQ(why, "a reset for robot 11 is already under way");
  const auto cancelled = node.cancel_all("cancelled by E-STOP ALL");
  ASSERT_EQ(cancelled.size(), 2u);
  EXPECT_EQ(cancelled[0].first, 41u);
  EXPECT_EQ(cancelled[0].second.message, "robot 10: cancelled by E-STOP ALL");
  EXPECT_FALSE(cancelled[1].second.ok());
  EXPECT_TRUE(node.idle());
  EXPECT_TRUE(node.poll(kNanosPerSecond).empty());
}

TEST(EstopReset, APressedEstopIsRefusedWithoutSending) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot pressed(4, StopReason::kEstop, true);
  const EstopResetResult r = reset_estop(base, request(4));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kCannotReset) << r.message;
  EXPECT_EQ(r.sent, 0);
  EXPECT_EQ(pressed.resets(), 0);
  EXPECT_NE(r.message.find("e-stop pressed"), std::string::npos) << r.message;
}

TEST(EstopReset, AnUnknownStopReasonIsNotTakenForUnlatched) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot odd(8, static_cast<StopReason>(200), true);
  const EstopResetResult r = reset_estop(base, request(8));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kCannotReset) << r.message;
  EXPECT_EQ(r.sent, 0);
  EXPECT_NE(r.message.find("stop reason 200"), std::string::npos) << r.message;
}

TEST(EstopReset, ARobotThatIsNotLatchedIsLeftAlone) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot running(5, StopReason::kNone, true);
  const EstopResetResult r = reset_estop(base, request(5));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kNotLatched) << r.message;
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.sent, 0);
}

TEST(EstopReset, AnAbsentRobotIsNamedAfterTheTimeout) {
  dds::Participant base(dds::loopback_profile(kDomain));
  FakeRobot other(6, StopReason::kResetRequired, true);
  const EstopResetResult r = reset_estop(base, request(7, 1 * kNanosPerSecond));
  EXPECT_EQ(r.outcome, EstopResetOutcome::kNoRobot) << r.message;
  EXPECT_EQ(other.resets(), 0);
  EXPECT_EQ(other.foreign_resets(), 0);
  EXPECT_NE(r.message.find("robot 7"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace cairn::base
