// The visit request exchange's logic (basestation/visit_request_machine.hpp) on simulated
// time: plain Nanos values stand for the clock, the test plays the base (its task
// assignments) and DDS (the matches, the writes). No thread, no sleep, no wall clock. The
// exchange over DDS is explore_node_test's.
#include "basestation/visit_request_machine.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace cairn::base {
namespace {

using Action = VisitRequestMachine::Action;
constexpr Nanos kMs = kNanosPerMilli;
constexpr Nanos kS = kNanosPerSecond;

VisitRequestOptions options() {
  VisitRequestOptions o;
  o.robot = 1;
  o.target = Vec2(2.5, -1.5);
  o.issued_by = "visit_request_machine_test";
  o.timeout = 10 * kS;
  o.confirm_wait = 3 * kS;
  o.history_wait = 300 * kMs;
  return o;
}

msg::TaskAssignment task(std::uint16_t robot, std::uint32_t id, msg::TaskKind kind, double x, double y) {
  msg::TaskAssignment t;
  t.robot_id = robot;
  t.task_id = id;
  t.kind = kind;
  t.target_x = x;
  t.target_y = y;
  return t;
}

// A base found at 100 ms, its task writer matched at 200 ms: the robot's history is read
// until 500 ms, then the first request is due.
VisitRequestMachine base_found() {
  VisitRequestMachine m(options(), 0);
  const VisitRequestMachine::Step find = m.next(0);
  EXPECT_EQ(find.action, Action::kFindBase);
  EXPECT_EQ(find.until, 10 * kS);
  m.on_base_found();
  EXPECT_EQ(m.next(100 * kMs).action, Action::kCheckTaskFeed);
  m.on_task_feed(100 * kMs, false);
  EXPECT_EQ(m.next(150 * kMs).action, Action::kCheckTaskFeed);
  m.on_task_feed(200 * kMs, true);
  const VisitRequestMachine::Step history = m.next(200 * kMs);
  EXPECT_EQ(history.action, Action::kWaitForTasks);
  EXPECT_EQ(history.until, 500 * kMs);
  return m;
}

TEST(VisitRequestMachine, ResendsOncePerConfirmWaitAndReportsUnconfirmedAtTheTimeout) {
  VisitRequestMachine m = base_found();
  std::vector<Nanos> sends;
  std::vector<std::uint32_t> seqs;
  // The base refuses (robot not localised): only the robot's unrelated exploration task.
  for (Nanos now = 200 * kMs; now <= 12 * kS && !m.done(); now += 50 * kMs) {
    m.on_task(task(1, 4, msg::TaskKind::kExplore, 6, 2));
    const VisitRequestMachine::Step step = m.next(now);
    if (step.action == Action::kSend) {
      sends.push_back(now);
      seqs.push_back(step.seq);
      m.on_sent(now);
    }
  }
  ASSERT_TRUE(m.done());
  EXPECT_EQ(sends, (std::vector<Nanos>{500 * kMs, 3500 * kMs, 6500 * kMs, 9500 * kMs}));
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 2, 3, 4}));
  const VisitResult& r = m.result();
  EXPECT_EQ(r.outcome, VisitOutcome::kUnconfirmed) << r.message;
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.sent, 4);
  EXPECT_NE(r.message.find("visit robot 1 to (2.50, -1.50): no task sent the robot there within 10 s after 4 sends"),
            std::string::npos)
      << r.message;
}

TEST(VisitRequestMachine, ANewGotoTaskToTheTargetConfirms) {
  VisitRequestMachine m = base_found();
  // The robot's current (latched) task: an earlier visit to the same place.
  m.on_task(task(1, 5, msg::TaskKind::kGoto, 2.5, -1.5));
  EXPECT_EQ(m.next(499 * kMs).action, Action::kWaitForTasks);
  const VisitRequestMachine::Step send = m.next(500 * kMs);
  ASSERT_EQ(send.action, Action::kSend);
  EXPECT_EQ(send.seq, 1u);
  m.on_sent(500 * kMs);
  // Neither the old task again, nor another robot's, nor a GOTO elsewhere confirms.
  m.on_task(task(1, 5, msg::TaskKind::kGoto, 2.5, -1.5));
  m.on_task(task(2, 9, msg::TaskKind::kGoto, 2.5, -1.5));
  m.on_task(task(1, 6, msg::TaskKind::kGoto, 2.5, -1.4));
  const VisitRequestMachine::Step wait = m.next(1 * kS);
  ASSERT_EQ(wait.action, Action::kWaitForTasks);
  EXPECT_EQ(wait.until, 3500 * kMs);
  m.on_task(task(1, 7, msg::TaskKind::kGoto, 2.5, -1.5));
  EXPECT_EQ(m.next(1100 * kMs).action, Action::kDone);
  const VisitResult& r = m.result();
  EXPECT_EQ(r.outcome, VisitOutcome::kConfirmed) << r.message;
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.task_id, 7u);
  EXPECT_EQ(r.sent, 1);
  EXPECT_EQ(r.message, "visit robot 1 to (2.50, -1.50): assigned as task 7 after 1 send");
}

TEST(VisitRequestMachine, AConfirmationAfterAResendCountsBothSends) {
  VisitRequestMachine m = base_found();
  ASSERT_EQ(m.next(500 * kMs).action, Action::kSend);
  m.on_sent(500 * kMs);
  EXPECT_EQ(m.next(3499 * kMs).action, Action::kWaitForTasks);
  const VisitRequestMachine::Step again = m.next(3500 * kMs);
  ASSERT_EQ(again.action, Action::kSend);
  EXPECT_EQ(again.seq, 2u);
  m.on_sent(3500 * kMs);
  m.on_task(task(1, 1, msg::TaskKind::kGoto, 2.5, -1.5));  // no task before: any id confirms
  EXPECT_EQ(m.next(3600 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, VisitOutcome::kConfirmed) << m.result().message;
  EXPECT_EQ(m.result().sent, 2);
  EXPECT_NE(m.result().message.find("after 2 sends"), std::string::npos) << m.result().message;
}

TEST(VisitRequestMachine, NoBaseIsReportedAtTheTimeoutWithoutSending) {
  VisitRequestMachine m(options(), 0);
  EXPECT_EQ(m.next(9999 * kMs).action, Action::kFindBase);
  EXPECT_EQ(m.next(10 * kS).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, VisitOutcome::kNoBase);
  EXPECT_EQ(m.result().sent, 0);
  EXPECT_NE(m.result().message.find("no base station reads visit requests"), std::string::npos) << m.result().message;
}

TEST(VisitRequestMachine, ATaskFeedThatNeverMatchesLeavesNoTimeToSend) {
  VisitRequestMachine m(options(), 0);
  m.on_base_found();
  for (Nanos now = 0; now < 10 * kS; now += 10 * kMs) {
    ASSERT_EQ(m.next(now).action, Action::kCheckTaskFeed) << now;
    m.on_task_feed(now, false);
  }
  m.on_task_feed(10 * kS, false);
  EXPECT_EQ(m.next(10 * kS).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, VisitOutcome::kUnconfirmed) << m.result().message;
  EXPECT_EQ(m.result().sent, 0);
}

TEST(VisitRequestMachine, AFailedWriteEndsTheExchangeUnconfirmed) {
  VisitRequestMachine m = base_found();
  ASSERT_EQ(m.next(500 * kMs).action, Action::kSend);
  m.on_send_failed("Out of resources");
  EXPECT_EQ(m.next(500 * kMs).action, Action::kDone);
  EXPECT_EQ(m.result().outcome, VisitOutcome::kUnconfirmed);
  EXPECT_NE(m.result().message.find("writing the request failed: Out of resources"), std::string::npos);
}

}  // namespace
}  // namespace cairn::base
