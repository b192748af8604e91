#include "basestation/visit_request.hpp"

#include <algorithm>

#include "common/dds/convert.hpp"
#include "common/dds/qos.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

VisitResult request_visit(const dds::Participant& pp, const VisitRequestOptions& o) {
  auto& clock = MonotonicClock::instance();
  VisitRequestMachine machine(o, clock.now());
  dds::Topic<cairn_VisitRequest> visit_topic(pp);
  dds::Writer<cairn_VisitRequest> writer(pp, visit_topic, dds::state_qos(1));
  dds::Topic<cairn_TaskAssignment> task_topic(pp);
  // Deeper than the base's writer: a GOTO replaced at once (a target within the arrival
  // radius, the end of exploration) must still be seen.
  dds::Reader<cairn_TaskAssignment> tasks(pp, task_topic, dds::latched_qos(8));

  for (;;) {
    const VisitRequestMachine::Step step = machine.next(clock.now());
    switch (step.action) {
      case VisitRequestMachine::Action::kDone: return machine.result();
      case VisitRequestMachine::Action::kFindBase:
        if (writer.wait_for_readers(1, step.until - clock.now())) machine.on_base_found();
        break;
      case VisitRequestMachine::Action::kCheckTaskFeed: {
        dds_subscription_matched_status_t matched{};
        const bool fed =
            dds_get_subscription_matched_status(tasks.handle(), &matched) == DDS_RETCODE_OK && matched.current_count > 0;
        machine.on_task_feed(clock.now(), fed);
        if (!fed && !machine.done()) dds_sleepfor(DDS_MSECS(10));
        break;
      }
      case VisitRequestMachine::Action::kWaitForTasks:
        tasks.wait(std::clamp<Nanos>(step.until - clock.now(), 0, 100 * kNanosPerMilli));
        tasks.take([&](const cairn_TaskAssignment& d, const dds_sample_info_t&) {
          // A malformed task still counts for the robot's latest id; its kind is then "stop".
          msg::TaskAssignment t;
          (void)dds::from_dds(d, &t);
          machine.on_task(t);
        });
        break;
      case VisitRequestMachine::Action::kSend: {
        cairn_VisitRequest r{};
        r.robot_id = o.robot;
        r.seq = step.seq;
        r.issued_ns = clock.now();
        r.x = o.target.x();
        r.y = o.target.y();
        dds::set_text(r.issued_by, o.issued_by);
        const Nanos sent_at = clock.now();
        if (!writer.write(r)) {
          machine.on_send_failed(dds_strretcode(writer.last_error()));
          break;
        }
        machine.on_sent(sent_at);
        break;
      }
    }
  }
}

}  // namespace cairn::base
