// The e-stop reset exchange (basestation/estop_reset.hpp) as a state machine on injected
// time: fed the robot's RobotStatus and whether our writer matched its reader, it says
// what to do next (wait for a status, check the match, send a reset) and when it is done
// with which outcome. No DDS, no clock, no sleeping: its retry and timeout logic is
// tested on simulated time (tests/basestation/estop_reset_machine_test.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "common/clock.hpp"
#include "common/stop_reason.hpp"

namespace cairn::base {

struct EstopResetRequest {
  std::uint16_t robot = 0;
  std::string issued_by;                      // SafetyReset.issued_by, e.g. "cairn-base base1"
  Nanos timeout = 10 * kNanosPerSecond;       // for the whole exchange
  Nanos confirm_wait = 2500 * kNanosPerMilli;  // per try: the robot's status period (1 s) + margin
};

enum class EstopResetOutcome {
  kConfirmed,    // the robot's status left "reset required" after our reset
  kNotLatched,   // its status says the latch is clear: nothing sent
  kCannotReset,  // e-stop pressed, its input stale or the CAN thread stalled: nothing sent, or it came back
  kNoRobot,      // no RobotStatus from this robot within the timeout
  kNotMatched,   // its status arrives but its reset reader never matched ours
  kUnconfirmed,  // sent (and acknowledged) but the status still says "reset required"
};
const char* estop_reset_outcome_name(EstopResetOutcome o);

struct EstopResetResult {
  EstopResetOutcome outcome = EstopResetOutcome::kNoRobot;
  StopReason last_reason = StopReason::kNone;  // the robot's last reported stop reason
  std::string last_text;                       // and its text
  int sent = 0;                                // SafetyReset samples written
  std::string message;                         // one line for the operator
  bool ok() const { return outcome == EstopResetOutcome::kConfirmed || outcome == EstopResetOutcome::kNotLatched; }
};

class EstopResetMachine {
 public:
  enum class Action {
    kWaitForStatus,  // take the robot's status samples (on_status) until `until`
    kCheckMatch,     // is our reset writer matched with the robot's reader? (on_match)
    kSend,           // write SafetyReset with `seq` (on_sent / on_send_failed)
    kDone,           // result() holds the outcome
  };
  struct Step {
    Action action = Action::kDone;
    Nanos until = 0;        // kWaitForStatus: wait no longer than this
    std::uint32_t seq = 0;  // kSend: the sample's seq
  };

  EstopResetMachine(const EstopResetRequest& request, Nanos start);

  /// What to do at `now`; kDone once the exchange has an outcome.
  Step next(Nanos now);
  /// A RobotStatus taken at `now` (any robot's: others are ignored).
  void on_status(Nanos now, std::uint16_t robot, StopReason reason, std::string_view text);
  /// The answer to kCheckMatch at `now`.
  void on_match(Nanos now, bool matched);
  /// The reset was written at `sent_at` (the time taken just before writing).
  void on_sent(Nanos sent_at);
  /// Writing failed: the exchange ends unconfirmed, with `error` in the message.
  void on_send_failed(const std::string& error);

  bool done() const { return phase_ == Phase::kDone; }
  Nanos deadline() const { return deadline_; }
  const EstopResetRequest& request() const { return request_; }
  const EstopResetResult& result() const { return result_; }

 private:
  enum class Phase { kListening, kMatching, kSending, kConfirming, kDone };
  void finish(EstopResetOutcome outcome, const std::string& why);
  std::string reason_line() const;
  std::string timeout_text() const;

  EstopResetRequest request_;
  Nanos deadline_;
  Phase phase_ = Phase::kListening;
  bool heard_ = false;
  Nanos heard_at_ = 0;  // when its latest status was taken
  Nanos sent_at_ = 0;   // the latest try
  Nanos try_end_ = 0;
  EstopResetResult result_;
};

}  // namespace cairn::base
