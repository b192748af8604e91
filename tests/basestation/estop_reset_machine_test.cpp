// The e-stop reset exchange's logic (basestation/estop_reset_machine.hpp) on simulated
// time: plain Nanos values stand for the clock, the test plays the robot (its statuses)
// and DDS (the match, the writes). No thread, no sleep, no wall clock. The exchange over
// DDS is estop_reset_test's.
#include "basestation/estop_reset_machine.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace cairn::base {
namespace {

using Action = EstopResetMachine::Action;
constexpr Nanos kMs = kNanosPerMilli;
constexpr Nanos kS = kNanosPerSecond;

EstopResetRequest request(std::uint16_t robot) {
  EstopResetRequest r;
  r.robot = robot;
  r.issued_by = "estop_reset_machine_test";
  r.timeout = 10 * kS;
  r.confirm_wait = 2500 * kMs;
  return r;
}

void status(EstopResetMachine* m, Nanos now, std::uint16_t robot, StopReason reason) {
  m->on_status(now, robot, reason, stop_reason_text(reason));
}

// Robot 3 latched, heard at 100 ms, its reader matched at 200 ms: the first send is due.
EstopResetMachine latched_and_matched() {
  EstopResetMachine m(request(3), 0);
  EXPECT_EQ(m.next(0).action, Action::kWaitForStatus);
  status(&m, 100 * kMs, 3, StopReason::kResetRequired);
  EXPECT_EQ(m.next(100 * kMs).action, Action::kCheckMatch);
  m.on_match(100 * kMs, false);
  EXPECT_EQ(m.next(150 * kMs).action, Action::kCheckMatch);
  m.on_match(200 * kMs, true);
  return m;
}

TEST(EstopResetMachine, ResendsOncePerConfirmWaitAndReportsUnconfirmedAtTheTimeout) {
  EstopResetMachine m = latched_and_matched();
  std::vector<Nanos> sends;
  std::vector<std::uint32_t> seqs;
  // The robot answers every 1 s, always still latched; the loop advances 50 ms at a time.
  for (Nanos now = 200 * kMs; now <= 12 * kS && !m.done(); now += 50 * kMs) {
    if (now % kS == 0) status(&m, now, 3, StopReason::kResetRequired);
    const EstopResetMachine::Step step = m.next(now);
    if (step.action == Action::kSend) {
      sends.push_back(now);
      seqs.push_back(step.seq);
      m.on_sent(now);
    } else if (step.action == Action::kWaitForStatus) {
      EXPECT_GT(step.until, now);
      EXPECT_LE(step.until, m.deadline());
    }
  }
  ASSERT_TRUE(m.done());
  // One try per confirm_wait (2.5 s) from the first send, none at or past the 10 s timeout.
  EXPECT_EQ(sends, (std::vector<Nanos>{200 * kMs, 2700 * kMs, 5200 * kMs, 7700 * kMs}));
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 2, 3, 4}));
  const EstopResetResult& r = m.result();
  EXPECT_EQ(r.outcome, EstopResetOutcome::kUnconfirmed) << r.message;
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.sent, 4);
  EXPECT_NE(r.message.find("still says stop reason 8"), std::string::npos) << r.message;
  EXPECT_EQ(m.next(20 * kS).action, Action::kDone);
}

TEST(EstopResetMachine, AStatusThatLeftTheLatchAfterTheResetConfirmsIt) {
  EstopResetMachine m = latched_and_matched();
  const EstopResetMachine::Step send = m.next(200 * kMs);
  ASSERT_EQ(send.action, Action::kSend);
  EXPECT_EQ(send.seq, 1u);
  m.on_sent(200 * kMs);
  // Written before the robot took the reset: still 8, not yet an answer.
  status(&m, 250 * kMs, 3, StopReason::kResetRequired);
  const EstopResetMachine::Step wait = m.next(250 * kMs);
  ASSERT_EQ(wait.action, Action::kWaitForStatus);
  EXPECT_EQ(wait.until, 2700 * kMs);  // the try lasts confirm_wait
  // Another robot's status changes nothing.
  status(&m, 300 * kMs, 4, StopReason::kNone);
  EXPECT_EQ(m.next(300 * kMs).action, Action::kWaitForStatus);
  status(&m, 1200 * kMs, 3, StopReason::kDrivesNotReady);
  EXPECT_EQ(m.next(1200 * kMs).action, Action::kDone);
  const EstopResetResult& r = m.result();
  EXPECT_EQ(r.outcome, EstopResetOutcome::kConfirmed) << r.message;
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.sent, 1);
  EXPECT_EQ(r.last_reason, StopReason::kDrivesNotReady);
  EXPECT_EQ(r.message, "robot 3: reset accepted after 1 send(s), now stop reason 2 (drives not operation enabled)");
}

TEST(EstopResetMachine, AConfirmationAfterAResendCountsBothSends) {
  EstopResetMachine m = latched_and_matched();
  ASSERT_EQ(m.next(200 * kMs).action, Action::kSend);
  m.on_sent(200 * kMs);
  EXPECT_EQ(m.next(2699 * kMs).action, Action::kWaitForStatus);
  const EstopResetMachine::Step again = m.next(2700 * kMs);
  ASSERT_EQ(again.action, Action::kSend);
  EXPECT_EQ(again.seq, 2u);
  m.on_sent(2700 * kMs);
  status(&m, 3 * kS, 3, StopReason::kNone);
  EXPECT_EQ(m.next(3 * kS).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kConfirmed) << m.result().message;
  EXPECT_EQ(m.result().sent, 2);
}

TEST(EstopResetMachine, APressedEstopIsRefusedWithoutSending) {
  EstopResetMachine m(request(4), 0);
  status(&m, 100 * kMs, 4, StopReason::kEstop);
  EXPECT_EQ(m.next(100 * kMs).action, Action::kDone);
  const EstopResetResult& r = m.result();
  EXPECT_EQ(r.outcome, EstopResetOutcome::kCannotReset) << r.message;
  EXPECT_EQ(r.sent, 0);
  EXPECT_NE(r.message.find("e-stop pressed"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("nothing sent"), std::string::npos) << r.message;
}

TEST(EstopResetMachine, AnUnknownStopReasonIsNotTakenForUnlatched) {
  EstopResetMachine m(request(8), 0);
  status(&m, 100 * kMs, 8, static_cast<StopReason>(200));
  EXPECT_EQ(m.next(100 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kCannotReset) << m.result().message;
  EXPECT_EQ(m.result().sent, 0);
  EXPECT_NE(m.result().message.find("stop reason 200"), std::string::npos) << m.result().message;
}

TEST(EstopResetMachine, ARobotThatIsNotLatchedIsLeftAlone) {
  EstopResetMachine m(request(5), 0);
  status(&m, 100 * kMs, 5, StopReason::kNone);
  EXPECT_EQ(m.next(100 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kNotLatched) << m.result().message;
  EXPECT_TRUE(m.result().ok());
  EXPECT_EQ(m.result().sent, 0);
}

TEST(EstopResetMachine, AnEstopPressedAfterTheResetIsReportedNotConfirmed) {
  EstopResetMachine m = latched_and_matched();
  ASSERT_EQ(m.next(200 * kMs).action, Action::kSend);
  m.on_sent(200 * kMs);
  status(&m, 1200 * kMs, 3, StopReason::kEstop);
  EXPECT_EQ(m.next(1200 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kCannotReset) << m.result().message;
  EXPECT_NE(m.result().message.find("reset sent, but now stop reason 1"), std::string::npos) << m.result().message;
}

TEST(EstopResetMachine, AnAbsentRobotIsNamedAtTheTimeout) {
  EstopResetMachine m(request(7), 0);
  // Robot 6 answers; robot 7 never does.
  for (Nanos now = 0; now < 10 * kS; now += 500 * kMs) {
    status(&m, now, 6, StopReason::kResetRequired);
    const EstopResetMachine::Step step = m.next(now);
    ASSERT_EQ(step.action, Action::kWaitForStatus) << now;
    EXPECT_EQ(step.until, 10 * kS);
  }
  EXPECT_EQ(m.next(10 * kS).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kNoRobot) << m.result().message;
  EXPECT_EQ(m.result().sent, 0);
  EXPECT_NE(m.result().message.find("robot 7: no RobotStatus"), std::string::npos) << m.result().message;
}

TEST(EstopResetMachine, AReaderThatNeverMatchesEndsTheExchangeAtTheTimeout) {
  EstopResetMachine m(request(3), 0);
  status(&m, 100 * kMs, 3, StopReason::kResetRequired);
  for (Nanos now = 100 * kMs; now < 10 * kS; now += 10 * kMs) {
    ASSERT_EQ(m.next(now).action, Action::kCheckMatch) << now;
    m.on_match(now, false);
  }
  m.on_match(10 * kS, false);
  EXPECT_EQ(m.next(10 * kS).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kNotMatched) << m.result().message;
  EXPECT_EQ(m.result().sent, 0);
}

TEST(EstopResetMachine, AFailedWriteEndsTheExchangeUnconfirmed) {
  EstopResetMachine m = latched_and_matched();
  ASSERT_EQ(m.next(200 * kMs).action, Action::kSend);
  m.on_send_failed("Out of resources");
  EXPECT_EQ(m.next(200 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, EstopResetOutcome::kUnconfirmed);
  EXPECT_EQ(m.result().sent, 0);
  EXPECT_NE(m.result().message.find("writing the reset failed: Out of resources"), std::string::npos);
}

}  // namespace
}  // namespace cairn::base
