// The visit request exchange (basestation/visit_request.hpp) as a state machine on
// injected time: fed whether a base reads our requests, whether the base's task writer
// matched our reader, and the TaskAssignments taken, it says what to do next (wait, send
// a request) and when it is done with which outcome. No DDS, no clock, no sleeping: its
// retry and timeout logic is tested on simulated time
// (tests/basestation/visit_request_machine_test.cpp).
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"
#include "common/messages.hpp"
#include "common/se2.hpp"

namespace cairn::base {

struct VisitRequestOptions {
  std::uint16_t robot = 0;
  Vec2 target = Vec2::Zero();  // global frame, m
  std::string issued_by;       // VisitRequest.issued_by, e.g. "cairn-base base1"
  Nanos timeout = 10 * kNanosPerSecond;        // for the whole exchange
  Nanos confirm_wait = 3 * kNanosPerSecond;    // per try: the base polls every 50 ms; margin for a loaded machine
  Nanos history_wait = 300 * kNanosPerMilli;   // to receive the robot's current (latched) task before writing
};

enum class VisitOutcome {
  kConfirmed,    // a new GOTO task for the robot to the target
  kNoBase,       // no reader of VisitRequest matched within the timeout
  kUnconfirmed,  // sent, but no such task came (refused by the base, or exploration is off)
};
const char* visit_outcome_name(VisitOutcome o);

struct VisitResult {
  VisitOutcome outcome = VisitOutcome::kNoBase;
  int sent = 0;               // VisitRequest samples written
  std::uint32_t task_id = 0;  // the confirming task
  std::string message;        // one line for the operator
  bool ok() const { return outcome == VisitOutcome::kConfirmed; }
};

class VisitRequestMachine {
 public:
  enum class Action {
    kFindBase,       // does a base read visit requests? wait for it until `until` (on_base_found)
    kCheckTaskFeed,  // is the base's task writer matched with our reader? (on_task_feed)
    kWaitForTasks,   // take TaskAssignments (on_task) until `until`
    kSend,           // write VisitRequest with `seq` (on_sent / on_send_failed)
    kDone,           // result() holds the outcome
  };
  struct Step {
    Action action = Action::kDone;
    Nanos until = 0;        // how long the wait may last
    std::uint32_t seq = 0;  // kSend: the sample's seq
  };

  VisitRequestMachine(const VisitRequestOptions& options, Nanos start);

  /// What to do at `now`; kDone once the exchange has an outcome.
  Step next(Nanos now);
  /// A reader of VisitRequest matched ours.
  void on_base_found();
  /// The answer to kCheckTaskFeed at `now`.
  void on_task_feed(Nanos now, bool matched);
  /// A TaskAssignment taken (any robot's: others are ignored).
  void on_task(const msg::TaskAssignment& task);
  /// The request was written at `sent_at` (the time taken just before writing).
  void on_sent(Nanos sent_at);
  /// Writing failed: the exchange ends unconfirmed, with `error` in the message.
  void on_send_failed(const std::string& error);

  bool done() const { return phase_ == Phase::kDone; }
  const VisitResult& result() const { return result_; }

 private:
  enum class Phase { kFindingBase, kMatchingTasks, kReadingHistory, kSending, kConfirming, kDone };
  void finish(VisitOutcome outcome, const std::string& why);

  VisitRequestOptions options_;
  Nanos deadline_;
  Phase phase_ = Phase::kFindingBase;
  Nanos history_end_ = 0;
  Nanos try_end_ = 0;
  // The robot's latest task id seen: only a task above it confirms, so the robot's current
  // (latched) task to the same place, from an earlier visit, does not.
  bool any_task_ = false;
  std::uint32_t last_task_ = 0;
  bool confirmed_ = false;
  VisitResult result_;
};

}  // namespace cairn::base
