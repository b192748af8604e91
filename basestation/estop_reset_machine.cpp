#include "basestation/estop_reset_machine.hpp"

#include <algorithm>

namespace cairn::base {

const char* estop_reset_outcome_name(EstopResetOutcome o) {
  switch (o) {
    case EstopResetOutcome::kConfirmed: return "confirmed";
    case EstopResetOutcome::kNotLatched: return "not latched";
    case EstopResetOutcome::kCannotReset: return "cannot reset";
    case EstopResetOutcome::kNoRobot: return "no robot";
    case EstopResetOutcome::kNotMatched: return "not matched";
    case EstopResetOutcome::kUnconfirmed: return "unconfirmed";
  }
  return "unknown";
}

namespace {

// A reason above the last one this build knows is one this base does not know: never taken for "clear".
bool unknown_reason(StopReason r) {
  return static_cast<std::uint8_t>(r) > static_cast<std::uint8_t>(kLastStopReason);
}

}  // namespace

EstopResetMachine::EstopResetMachine(const EstopResetRequest& request, Nanos start)
    : request_(request), deadline_(start + request.timeout) {}

EstopResetMachine::Step EstopResetMachine::next(Nanos now) {
  switch (phase_) {
    case Phase::kDone: return {};
    case Phase::kListening: {
      // A status taken is judged before the time is: one that came just in time counts.
      if (!heard_) {
        if (now >= deadline_) {
          finish(EstopResetOutcome::kNoRobot, "no RobotStatus on this DDS domain within " + timeout_text() +
                                                  " s: is it running, on this domain?");
          return {};
        }
        return {Action::kWaitForStatus, deadline_, 0};
      }
      const StopReason r = result_.last_reason;
      if (unknown_reason(r)) {
        finish(EstopResetOutcome::kCannotReset, reason_line() + ": a stop reason this base does not know; nothing sent");
      } else if (r != StopReason::kResetRequired && stop_reason_masks_latch(r)) {
        finish(EstopResetOutcome::kCannotReset,
               reason_line() + ": a reset is accepted only with the e-stop released, its input fresh and the "
                               "wheel feedback flowing; nothing sent");
      } else if (r != StopReason::kResetRequired) {
        finish(EstopResetOutcome::kNotLatched, "not latched, " + reason_line() + "; nothing sent");
      } else {
        phase_ = Phase::kMatching;
        return next(now);
      }
      return {};
    }
    case Phase::kMatching: return {Action::kCheckMatch, deadline_, 0};
    case Phase::kSending:
      if (now >= deadline_) {
        finish(EstopResetOutcome::kUnconfirmed, "sent " + std::to_string(result_.sent) +
                                                    " reset(s), acknowledged, but its status still says " + reason_line());
        return {};
      }
      return {Action::kSend, deadline_, static_cast<std::uint32_t>(result_.sent + 1)};
    case Phase::kConfirming:
      // A status taken before this try may still say 8 (written before the robot took the
      // reset); only a later one that left 8 decides.
      if (heard_at_ > sent_at_ && result_.last_reason != StopReason::kResetRequired) {
        if (stop_reason_masks_latch(result_.last_reason) || unknown_reason(result_.last_reason)) {
          finish(EstopResetOutcome::kCannotReset, "reset sent, but now " + reason_line());
        } else {
          finish(EstopResetOutcome::kConfirmed,
                 "reset accepted after " + std::to_string(result_.sent) + " send(s), now " + reason_line());
        }
        return {};
      }
      if (now >= try_end_) {
        phase_ = Phase::kSending;  // resend (next seq) while time is left
        return next(now);
      }
      return {Action::kWaitForStatus, try_end_, 0};
  }
  return {};
}

void EstopResetMachine::on_status(Nanos now, std::uint16_t robot, StopReason reason, std::string_view text) {
  if (phase_ == Phase::kDone || robot != request_.robot) return;
  result_.last_reason = reason;
  result_.last_text.assign(text);
  heard_ = true;
  heard_at_ = now;
}

void EstopResetMachine::on_match(Nanos now, bool matched) {
  if (phase_ != Phase::kMatching) return;
  if (matched) {
    phase_ = Phase::kSending;
  } else if (now >= deadline_) {
    finish(EstopResetOutcome::kNotMatched,
           "its status arrives but its SafetyReset reader never matched ours within " + timeout_text() + " s");
  }
}

void EstopResetMachine::on_sent(Nanos sent_at) {
  if (phase_ != Phase::kSending) return;
  ++result_.sent;
  sent_at_ = sent_at;
  try_end_ = std::min(deadline_, sent_at + request_.confirm_wait);
  phase_ = Phase::kConfirming;
}

void EstopResetMachine::on_send_failed(const std::string& error) {
  if (phase_ != Phase::kSending) return;
  finish(EstopResetOutcome::kUnconfirmed, "writing the reset failed: " + error);
}

void EstopResetMachine::finish(EstopResetOutcome outcome, const std::string& why) {
  result_.outcome = outcome;
  result_.message = "robot " + std::to_string(request_.robot) + ": " + why;
  phase_ = Phase::kDone;
}

std::string EstopResetMachine::reason_line() const {
  return "stop reason " + std::to_string(static_cast<int>(result_.last_reason)) + " (" +
         (result_.last_text.empty() ? stop_reason_text(result_.last_reason) : result_.last_text) + ")";
}

std::string EstopResetMachine::timeout_text() const { return std::to_string(nanos_to_seconds(request_.timeout)); }

}  // namespace cairn::base
