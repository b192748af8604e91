// The safety supervisor's e-stop latch and staleness bounds, on simulated time (the
// subject is logic: every time arrives with the inputs). The threaded paths (the e-stop
// fast path, torque off on the CAN bus, motor power through the board) are measured in
// executive_hil_test.
#include "firmware/executive/safety.hpp"

#include <gtest/gtest.h>

#include "common/clock.hpp"

#include <limits>

namespace cairn::firmware {
namespace {

constexpr Nanos kPeriod = 10 * kNanosPerMilli;
constexpr double kDt = 0.01;

// A healthy robot on simulated time: every input fresh each cycle unless a test says otherwise.
struct Robot {
  SimClock clock{kNanosPerSecond};
  SafetySupervisor safety{SafetyLimits{}};
  bool estop = false, power_ok = true, feedback_ok = true, can_ok = true, enabled = true;
  Nanos last_power = -1, last_feedback = -1, last_can = -1;
  double v = 0, w = 0;
  double want_v = 0.5, want_w = 0.0;
  double field_forward = std::numeric_limits<double>::infinity();  // the protective field's limit
  double field_reverse = std::numeric_limits<double>::infinity();
  double field_brake = std::numeric_limits<double>::infinity();

  StopReason cycle(bool reset = false, bool remote_stop = false) {
    clock.advance(kPeriod);
    const Nanos now = clock.now();
    if (power_ok) last_power = now;
    if (feedback_ok) last_feedback = now;
    if (can_ok) last_can = now;
    SafetyInputs in;
    in.now = now;
    in.estop = estop;
    in.drives_enabled = enabled;
    in.last_link = in.last_scan = in.last_command = now;
    in.last_power = last_power;
    in.last_feedback = last_feedback;
    in.last_can_pass = last_can;
    in.reset = reset;
    in.remote_stop = remote_stop;
    in.v = want_v;
    in.w = want_w;
    in.field_forward_max_v = field_forward;
    in.field_reverse_max_v = field_reverse;
    in.field_brake_max_v = field_brake;
    return safety.evaluate(in, kDt, &v, &w);
  }
  // Runs until moving (or gives up): the ramp takes a few cycles.
  bool moves_within(int cycles) {
    for (int i = 0; i < cycles; ++i) {
      if (cycle() == StopReason::kNone && v > 0) return true;
    }
    return false;
  }
  // Cycles until the reason is not kNone; returns the simulated time that took (-1: never).
  Nanos time_to_stop(Nanos limit) {
    const Nanos t0 = clock.now();
    while (clock.now() - t0 <= limit) {
      if (cycle() != StopReason::kNone) return clock.now() - t0;
    }
    return -1;
  }
};

TEST(SafetyLatch, ReleasingTheEstopDoesNotRestartOnlyAResetDoes) {
  Robot r;
  ASSERT_TRUE(r.moves_within(5));
  r.estop = true;
  EXPECT_EQ(r.cycle(), StopReason::kEstop);
  EXPECT_EQ(r.v, 0.0);
  EXPECT_TRUE(r.safety.latched());
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kEstop);
  // A reset while the e-stop is still pressed is refused and forgotten.
  EXPECT_EQ(r.cycle(true), StopReason::kEstop);
  EXPECT_EQ(r.safety.resets_refused(), 1u);
  r.estop = false;
  // Released: stopped, for as long as nobody resets (an hour of simulated time).
  for (int i = 0; i < 360000; ++i) {
    ASSERT_EQ(r.cycle(), StopReason::kResetRequired) << "cycle " << i;
    ASSERT_EQ(r.v, 0.0);
  }
  EXPECT_TRUE(r.safety.latched());
  EXPECT_EQ(r.safety.resets_accepted(), 0u);  // the refused reset was not remembered
  // The reset: accepted once, then the robot may move (ramped).
  EXPECT_EQ(r.cycle(true), StopReason::kNone);
  EXPECT_TRUE(r.safety.reset_accepted());
  EXPECT_FALSE(r.safety.latched());
  EXPECT_EQ(r.safety.resets_accepted(), 1u);
  EXPECT_TRUE(r.moves_within(3));
  EXPECT_FALSE(r.safety.reset_accepted());  // one cycle only
  // A reset when nothing is latched does nothing.
  r.cycle(true);
  EXPECT_EQ(r.safety.resets_accepted(), 1u);
  EXPECT_EQ(r.safety.resets_refused(), 1u);
}

// The base's remote e-stop (SafetyStop): a momentary press from afar. It stops the robot in
// the cycle it arrives and latches; a reset in that same cycle is refused (a stop and a reset
// racing over the network must not cancel out); a later reset is accepted.
TEST(SafetyLatch, ARemoteStopLatchesAtOnceAndARacingResetIsRefused) {
  Robot r;
  ASSERT_TRUE(r.moves_within(5));
  EXPECT_EQ(r.cycle(true, true), StopReason::kResetRequired);
  EXPECT_EQ(r.v, 0.0);
  EXPECT_TRUE(r.safety.latched());
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kRemoteStop);
  EXPECT_STREQ(latch_cause_text(r.safety.latch_cause()), "remote e-stop");
  EXPECT_EQ(r.safety.resets_refused(), 1u);
  EXPECT_EQ(r.safety.resets_accepted(), 0u);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(r.cycle(), StopReason::kResetRequired) << "cycle " << i;
  // A second stop while latched keeps the first cause; then the reset.
  EXPECT_EQ(r.cycle(false, true), StopReason::kResetRequired);
  EXPECT_EQ(r.cycle(true), StopReason::kNone);
  EXPECT_TRUE(r.safety.reset_accepted());
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kNone);
  EXPECT_TRUE(r.moves_within(3));
  // A pressed e-stop latched first stays the cause a later remote stop does not overwrite.
  r.estop = true;
  r.cycle(false, true);
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kEstop);
}

TEST(SafetyLatch, AStaleEstopInputStopsWithinItsBoundAndLatches) {
  Robot r;
  ASSERT_TRUE(r.moves_within(5));
  r.power_ok = false;  // the board stops answering: the last good read is now
  const Nanos t = r.time_to_stop(kNanosPerSecond);
  // Stale once older than power_timeout (50 ms); the check runs each 10 ms cycle.
  EXPECT_GT(t, SafetyLimits{}.power_timeout);
  EXPECT_LE(t, SafetyLimits{}.power_timeout + kPeriod);
  EXPECT_EQ(r.safety.reason(), StopReason::kPowerLost);
  EXPECT_TRUE(r.safety.latched());
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kEstopInputLost);
  EXPECT_EQ(r.cycle(true), StopReason::kPowerLost);  // a reset while it is silent: refused
  r.power_ok = true;                                   // back, e-stop released
  for (int i = 0; i < 100; ++i) ASSERT_EQ(r.cycle(), StopReason::kResetRequired);
  EXPECT_EQ(r.cycle(true), StopReason::kNone);
  EXPECT_TRUE(r.moves_within(3));
}

TEST(SafetyLatch, NoInputYetAtBootStopsButDoesNotLatch) {
  Robot r;
  r.power_ok = false;  // never heard
  EXPECT_EQ(r.cycle(), StopReason::kPowerLost);
  EXPECT_FALSE(r.safety.latched());
  r.power_ok = true;
  EXPECT_TRUE(r.moves_within(5));
}

TEST(SafetyLatch, StaleWheelFeedbackStopsWithinItsBoundAndRecoversWithoutAReset) {
  Robot r;
  ASSERT_TRUE(r.moves_within(5));
  r.feedback_ok = false;  // no TPDO from a drive, the CAN thread still cycling
  const Nanos t = r.time_to_stop(kNanosPerSecond);
  EXPECT_GT(t, SafetyLimits{}.feedback_timeout);
  EXPECT_LE(t, SafetyLimits{}.feedback_timeout + kPeriod);
  EXPECT_EQ(r.safety.reason(), StopReason::kFeedbackStale);
  EXPECT_FALSE(r.safety.latched());  // the CAN thread can still command zero
  r.feedback_ok = true;
  EXPECT_TRUE(r.moves_within(5));
  // Drives not enabled (booting): no TPDOs are expected, not a feedback stop.
  r.feedback_ok = false;
  r.enabled = false;
  for (int i = 0; i < 20; ++i) ASSERT_EQ(r.cycle(), StopReason::kDrivesNotReady);
}

TEST(SafetyLatch, AStalledCanThreadStopsWithinItsBoundLatchesAndNeedsAReset) {
  Robot r;
  ASSERT_TRUE(r.moves_within(5));
  r.can_ok = false;  // the CAN thread hangs: no pass, no feedback
  r.feedback_ok = false;
  const Nanos t = r.time_to_stop(kNanosPerSecond);
  EXPECT_GT(t, SafetyLimits{}.feedback_timeout);
  EXPECT_LE(t, SafetyLimits{}.feedback_timeout + kPeriod);
  EXPECT_EQ(r.safety.reason(), StopReason::kFeedbackStale);
  EXPECT_TRUE(r.safety.latched());
  EXPECT_EQ(r.safety.latch_cause(), LatchCause::kCanStalled);
  r.can_ok = r.feedback_ok = true;
  for (int i = 0; i < 100; ++i) ASSERT_EQ(r.cycle(), StopReason::kResetRequired);
  EXPECT_EQ(r.cycle(true), StopReason::kNone);
  EXPECT_TRUE(r.moves_within(3));
}

// The protective field (protective_field.hpp) is a speed limit: slowed with the curvature
// kept, stopped at once when blocked or too fast to brake in time, never latched.
TEST(ProtectiveFieldStop, SlowsKeepingTheCurveStopsWhenBlockedAndClearsWithoutAReset) {
  Robot r;
  r.want_v = 0.6;
  r.want_w = 0.3;
  for (int i = 0; i < 100; ++i) ASSERT_EQ(r.cycle(), StopReason::kNone);
  ASSERT_NEAR(r.v, 0.6, 1e-9);
  // The limit falls to 0.3 m/s as an obstacle nears (slower than braking at max_acc): the
  // robot follows it, the curvature w/v stays 0.5.
  for (int i = 0; i < 100; ++i) {
    r.field_forward = std::max(0.3, 0.6 - 0.005 * i);
    ASSERT_EQ(r.cycle(), StopReason::kNone) << i;
  }
  EXPECT_NEAR(r.v, 0.3, 1e-9);
  EXPECT_NEAR(r.w / r.v, 0.5, 1e-9);
  // Blocked: stopped at once, turn too, with its reason.
  r.field_forward = 0.0;
  EXPECT_EQ(r.cycle(), StopReason::kProtectiveField);
  EXPECT_EQ(r.v, 0.0);
  EXPECT_EQ(r.w, 0.0);
  // Turning in place is still allowed; the field is no latch: clear, it moves again.
  r.want_v = 0.0;
  EXPECT_EQ(r.cycle(), StopReason::kNone);
  EXPECT_GT(r.w, 0.0);
  r.want_v = 0.6;
  r.field_forward = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(r.moves_within(5));
  EXPECT_FALSE(r.safety.latched());
}

TEST(ProtectiveFieldStop, SomethingSteppingInCloserThanBrakingReachesStopsAtOnce) {
  Robot r;
  r.want_v = 0.8;
  for (int i = 0; i < 200; ++i) r.cycle();
  ASSERT_NEAR(r.v, 0.8, 1e-9);
  // Allowed 0.5, but braking from now still stops in time (0.9): ramp down at max_acc.
  r.field_forward = 0.5;
  r.field_brake = 0.9;
  EXPECT_EQ(r.cycle(), StopReason::kNone);
  EXPECT_NEAR(r.v, 0.792, 1e-9);
  // Braking from now would not stop in time (0.5 < 0.792): stop now.
  r.field_brake = 0.5;
  EXPECT_EQ(r.cycle(), StopReason::kProtectiveField);
  EXPECT_EQ(r.v, 0.0);
  // A NaN limit is no licence to move.
  r.field_brake = std::numeric_limits<double>::infinity();
  r.field_forward = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(r.cycle(), StopReason::kProtectiveField);
  EXPECT_EQ(r.v, 0.0);
}

TEST(ProtectiveFieldStop, ReverseIsCapped) {
  Robot r;
  r.want_v = -0.5;
  r.field_reverse = 0.1;
  for (int i = 0; i < 100; ++i) ASSERT_EQ(r.cycle(), StopReason::kNone);
  EXPECT_NEAR(r.v, -0.1, 1e-9);
}

}  // namespace
}  // namespace cairn::firmware
