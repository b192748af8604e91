// The operator's e-stop reset for one robot (`cairn-base --reset-estop ID`), delivered and
// confirmed: SafetyReset is volatile (a robot started later must never act on an old
// reset), so a sample written before the robot's reader is matched is simply lost. With
// several robots on the domain, "some reader matched" is not "this robot's reader
// matched". So: wait for the robot's RobotStatus, wait until the reset writer is matched
// with a reader of that same participant, write, and watch the robot's status leave
// "reset required"; resend (next seq) until it does or the time is up.
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"
#include "common/dds/participant.hpp"
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

/// Runs the exchange on `pp` (wall clock; it blocks for at most request.timeout).
EstopResetResult reset_estop(const dds::Participant& pp, const EstopResetRequest& request);

}  // namespace cairn::base
