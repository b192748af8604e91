#include "basestation/estop_reset.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <string_view>

#include "common/dds/qos.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

namespace {

bool same_guid(const dds_guid_t& a, const dds_guid_t& b) { return std::memcmp(a.v, b.v, sizeof a.v) == 0; }

/// The participant that wrote the sample `publication` (a handle from its sample info).
bool publisher_participant(dds_entity_t reader, dds_instance_handle_t publication, dds_guid_t* out) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (!ep) return false;
  *out = ep->participant_key;
  dds_builtintopic_free_endpoint(ep);
  return true;
}

/// Whether `writer` is matched with a reader that belongs to `participant`.
bool matched_with(dds_entity_t writer, const dds_guid_t& participant) {
  std::array<dds_instance_handle_t, 64> handles{};
  const dds_return_t n = dds_get_matched_subscriptions(writer, handles.data(), handles.size());
  for (dds_return_t i = 0; i < n && i < static_cast<dds_return_t>(handles.size()); ++i) {
    dds_builtintopic_endpoint_t* ep = dds_get_matched_subscription_data(writer, handles[static_cast<std::size_t>(i)]);
    if (!ep) continue;
    const bool same = same_guid(ep->participant_key, participant);
    dds_builtintopic_free_endpoint(ep);
    if (same) return true;
  }
  return false;
}

}  // namespace

EstopResetResult reset_estop(const dds::Participant& pp, const EstopResetRequest& req) {
  auto& clock = MonotonicClock::instance();
  EstopResetMachine machine(req, clock.now());
  dds::Topic<cairn_RobotStatus> status_topic(pp);
  dds::Reader<cairn_RobotStatus> status(pp, status_topic, dds::state_qos(4));
  dds::Topic<cairn_SafetyReset> reset_topic(pp);
  dds::Writer<cairn_SafetyReset> writer(pp, reset_topic, dds::state_qos(4));
  dds_guid_t robot_participant{};  // the participant its latest status came from

  for (;;) {
    const EstopResetMachine::Step step = machine.next(clock.now());
    switch (step.action) {
      case EstopResetMachine::Action::kDone: return machine.result();
      case EstopResetMachine::Action::kWaitForStatus: {
        bool got = false;
        status.take([&](const cairn_RobotStatus& s, const dds_sample_info_t& info) {
          if (s.robot_id != req.robot) return;
          dds_guid_t p{};
          if (!publisher_participant(status.handle(), info.publication_handle, &p)) return;
          robot_participant = p;
          machine.on_status(clock.now(), s.robot_id, static_cast<StopReason>(s.stop_reason),
                            std::string_view(s.stop_text, strnlen(s.stop_text, sizeof s.stop_text)));
          got = true;
        });
        const Nanos now = clock.now();
        if (!got && now < step.until) status.wait(std::min<Nanos>(step.until - now, 100 * kNanosPerMilli));
        break;
      }
      case EstopResetMachine::Action::kCheckMatch: {
        // Its status came from a participant whose reset reader must be matched with our writer.
        const bool matched = matched_with(writer.handle(), robot_participant);
        machine.on_match(clock.now(), matched);
        if (!matched && !machine.done()) dds_sleepfor(DDS_MSECS(10));
        break;
      }
      case EstopResetMachine::Action::kSend: {
        cairn_SafetyReset r{};
        r.robot_id = req.robot;
        r.seq = step.seq;
        r.issued_ns = clock.now();
        dds::set_text(r.issued_by, req.issued_by);
        const Nanos sent_at = clock.now();
        if (!writer.write(r)) {
          machine.on_send_failed(dds_strretcode(writer.last_error()));
          break;
        }
        machine.on_sent(sent_at);
        dds_wait_for_acks(writer.handle(), std::max<Nanos>(0, std::min(machine.deadline() - clock.now(), 2 * kNanosPerSecond)));
        break;
      }
    }
  }
}

}  // namespace cairn::base
