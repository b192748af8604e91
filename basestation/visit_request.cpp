#include "basestation/visit_request.hpp"

#include <algorithm>
#include <cstdio>

#include "common/dds/qos.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

const char* visit_outcome_name(VisitOutcome o) {
  switch (o) {
    case VisitOutcome::kConfirmed: return "confirmed";
    case VisitOutcome::kNoBase: return "no base";
    case VisitOutcome::kUnconfirmed: return "unconfirmed";
  }
  return "unknown";
}

VisitResult request_visit(const dds::Participant& pp, const VisitRequestOptions& o) {
  auto& clock = MonotonicClock::instance();
  const Nanos deadline = clock.now() + o.timeout;
  char where[96];
  std::snprintf(where, sizeof where, "robot %u to (%.2f, %.2f)", static_cast<unsigned>(o.robot), o.target.x(),
                o.target.y());
  dds::Topic<cairn_VisitRequest> visit_topic(pp);
  dds::Writer<cairn_VisitRequest> writer(pp, visit_topic, dds::state_qos(1));
  dds::Topic<cairn_TaskAssignment> task_topic(pp);
  // Deeper than the base's writer: a GOTO replaced at once (a target within the arrival
  // radius, the end of exploration) must still be seen.
  dds::Reader<cairn_TaskAssignment> tasks(pp, task_topic, dds::latched_qos(8));

  VisitResult res;
  auto finish = [&](VisitOutcome outcome, const std::string& why) {
    res.outcome = outcome;
    res.message = std::string("visit ") + where + ": " + why;
    return res;
  };
  if (!writer.wait_for_readers(1, o.timeout)) {
    return finish(VisitOutcome::kNoBase, "no base station reads visit requests on this DDS domain (is cairn-base "
                                         "running, with [explore] enabled?)");
  }
  // The robot's current task (latched) arrives first: only a task id above it confirms, so
  // an earlier visit to the same place does not. Its history can only come once the base's
  // task writer is matched: wait for that, then a little for the sample.
  dds_subscription_matched_status_t matched{};
  while (clock.now() < deadline &&
         !(dds_get_subscription_matched_status(tasks.handle(), &matched) == DDS_RETCODE_OK && matched.current_count > 0)) {
    dds_sleepfor(DDS_MSECS(10));
  }
  bool any_task = false;
  std::uint32_t last_task = 0;
  bool confirmed = false;
  auto take_tasks = [&](bool after_write) {
    tasks.take([&](const cairn_TaskAssignment& t, const dds_sample_info_t&) {
      if (t.robot_id != o.robot) return;
      if (after_write && (!any_task || t.task_id > last_task) && t.kind == cairn_TASK_GOTO &&
          t.target_x == o.target.x() && t.target_y == o.target.y()) {
        confirmed = true;
        res.task_id = t.task_id;
      }
      last_task = std::max(last_task, t.task_id);
      any_task = true;
    });
  };
  const Nanos history_end = std::min(deadline, clock.now() + o.history_wait);
  while (clock.now() < history_end) {
    tasks.wait(history_end - clock.now());
    take_tasks(false);
  }
  while (clock.now() < deadline) {
    cairn_VisitRequest r{};
    r.robot_id = o.robot;
    r.seq = static_cast<std::uint32_t>(res.sent + 1);
    r.issued_ns = clock.now();
    r.x = o.target.x();
    r.y = o.target.y();
    dds::set_text(r.issued_by, o.issued_by);
    const Nanos sent_at = clock.now();
    if (!writer.write(r)) {
      return finish(VisitOutcome::kUnconfirmed, std::string("writing the request failed: ") +
                                                   dds_strretcode(writer.last_error()));
    }
    ++res.sent;
    const Nanos try_end = std::min(deadline, sent_at + o.confirm_wait);
    while (!confirmed && clock.now() < try_end) {
      tasks.wait(std::min<Nanos>(try_end - clock.now(), 100 * kNanosPerMilli));
      take_tasks(true);
    }
    if (confirmed) {
      return finish(VisitOutcome::kConfirmed, "assigned as task " + std::to_string(res.task_id) + " after " +
                                                  std::to_string(res.sent) + (res.sent == 1 ? " send" : " sends"));
    }
  }
  return finish(VisitOutcome::kUnconfirmed,
                "no task sent the robot there within " + std::to_string(static_cast<int>(nanos_to_seconds(o.timeout))) +
                    " s after " + std::to_string(res.sent) +
                    " sends: the base refuses a robot it has not localised or has lost and a target beyond 10 km, and "
                    "assigns nothing with exploration off (its explore: line counts refusals)");
}

}  // namespace cairn::base
