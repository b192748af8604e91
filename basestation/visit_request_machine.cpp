#include "basestation/visit_request_machine.hpp"

#include <algorithm>
#include <cstdio>

namespace cairn::base {

const char* visit_outcome_name(VisitOutcome o) {
  switch (o) {
    case VisitOutcome::kConfirmed: return "confirmed";
    case VisitOutcome::kNoBase: return "no base";
    case VisitOutcome::kUnconfirmed: return "unconfirmed";
  }
  return "unknown";
}

VisitRequestMachine::VisitRequestMachine(const VisitRequestOptions& options, Nanos start)
    : options_(options), deadline_(start + options.timeout) {}

VisitRequestMachine::Step VisitRequestMachine::next(Nanos now) {
  switch (phase_) {
    case Phase::kDone: return {};
    case Phase::kFindingBase:
      if (now >= deadline_) {
        finish(VisitOutcome::kNoBase, "no base station reads visit requests on this DDS domain (is cairn-base "
                                      "running, with [explore] enabled?)");
        return {};
      }
      return {Action::kFindBase, deadline_, 0};
    case Phase::kMatchingTasks: return {Action::kCheckTaskFeed, deadline_, 0};
    case Phase::kReadingHistory:
      if (now >= history_end_) {
        phase_ = Phase::kSending;
        return next(now);
      }
      return {Action::kWaitForTasks, history_end_, 0};
    case Phase::kSending:
      if (now >= deadline_) {
        finish(VisitOutcome::kUnconfirmed,
               "no task sent the robot there within " + std::to_string(static_cast<int>(nanos_to_seconds(options_.timeout))) +
                   " s after " + std::to_string(result_.sent) +
                   " sends: the base refuses a robot it has not localised or has lost and a target beyond 10 km, and "
                   "assigns nothing with exploration off (its explore: line counts refusals)");
        return {};
      }
      return {Action::kSend, deadline_, static_cast<std::uint32_t>(result_.sent + 1)};
    case Phase::kConfirming:
      if (confirmed_) {
        finish(VisitOutcome::kConfirmed, "assigned as task " + std::to_string(result_.task_id) + " after " +
                                             std::to_string(result_.sent) + (result_.sent == 1 ? " send" : " sends"));
        return {};
      }
      if (now >= try_end_) {
        phase_ = Phase::kSending;  // resend (next seq) while time is left
        return next(now);
      }
      return {Action::kWaitForTasks, try_end_, 0};
  }
  return {};
}

void VisitRequestMachine::on_base_found() {
  if (phase_ == Phase::kFindingBase) phase_ = Phase::kMatchingTasks;
}

void VisitRequestMachine::on_task_feed(Nanos now, bool matched) {
  if (phase_ != Phase::kMatchingTasks) return;
  // The robot's current task can only arrive once the base's task writer is matched; past
  // the deadline there is no time left to read it (nor to send).
  if (!matched && now < deadline_) return;
  history_end_ = std::min(deadline_, now + options_.history_wait);
  phase_ = Phase::kReadingHistory;
}

void VisitRequestMachine::on_task(const msg::TaskAssignment& t) {
  if (phase_ == Phase::kDone || t.robot_id != options_.robot) return;
  const bool after_write = result_.sent > 0;
  if (after_write && (!any_task_ || t.task_id > last_task_) && t.kind == msg::TaskKind::kGoto &&
      t.target_x == options_.target.x() && t.target_y == options_.target.y()) {
    confirmed_ = true;
    result_.task_id = t.task_id;
  }
  last_task_ = std::max(last_task_, t.task_id);
  any_task_ = true;
}

void VisitRequestMachine::on_sent(Nanos sent_at) {
  if (phase_ != Phase::kSending) return;
  ++result_.sent;
  try_end_ = std::min(deadline_, sent_at + options_.confirm_wait);
  phase_ = Phase::kConfirming;
}

void VisitRequestMachine::on_send_failed(const std::string& error) {
  if (phase_ != Phase::kSending) return;
  finish(VisitOutcome::kUnconfirmed, "writing the request failed: " + error);
}

void VisitRequestMachine::finish(VisitOutcome outcome, const std::string& why) {
  char where[96];
  std::snprintf(where, sizeof where, "robot %u to (%.2f, %.2f)", static_cast<unsigned>(options_.robot),
                options_.target.x(), options_.target.y());
  result_.outcome = outcome;
  result_.message = std::string("visit ") + where + ": " + why;
  phase_ = Phase::kDone;
}

}  // namespace cairn::base
