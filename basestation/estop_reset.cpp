#include "basestation/estop_reset.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <string_view>

#include "common/dds/qos.hpp"

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

EstopResetNode::EstopResetNode(const dds::Participant& pp, std::size_t max_running)
    : max_running_(max_running), topic_(pp), writer_(pp, topic_, dds::state_qos(4)) {}

bool EstopResetNode::start(std::uint64_t id, const EstopResetRequest& request, Nanos now, std::string* why) {
  if (running_.contains(request.robot)) {
    *why = "a reset for robot " + std::to_string(request.robot) + " is already under way";
    return false;
  }
  if (running_.size() >= max_running_) {
    *why = "busy: " + std::to_string(max_running_) + " resets under way";
    return false;
  }
  Exchange e{id, EstopResetMachine(request, now), {}, {}};
  e.step = e.machine.next(now);
  running_.emplace(request.robot, std::move(e));
  return true;
}

void EstopResetNode::on_status(dds_entity_t reader, const cairn_RobotStatus& s, const dds_sample_info_t& info, Nanos now) {
  const auto it = running_.find(s.robot_id);
  if (it == running_.end()) return;
  dds_guid_t p{};
  if (!publisher_participant(reader, info.publication_handle, &p)) return;
  it->second.participant = p;
  if (!it->second.stops_known) {
    it->second.stops_known = true;
    it->second.remote_stops = s.remote_stops;
  }
  it->second.machine.on_status(now, s.robot_id, static_cast<StopReason>(s.stop_reason),
                               std::string_view(s.stop_text, strnlen(s.stop_text, sizeof s.stop_text)));
}

bool EstopResetNode::matching() const {
  return std::any_of(running_.begin(), running_.end(),
                     [](const auto& kv) { return kv.second.step.action == EstopResetMachine::Action::kCheckMatch; });
}

std::vector<std::pair<std::uint64_t, EstopResetResult>> EstopResetNode::poll(Nanos now) {
  std::vector<std::pair<std::uint64_t, EstopResetResult>> done;
  for (auto it = running_.begin(); it != running_.end();) {
    Exchange& e = it->second;
    // A few steps per poll: a status may lead to a match check and a send at once; an
    // unmatched writer is checked again at the next poll, not in a loop here.
    for (int k = 0; k < 4; ++k) {
      e.step = e.machine.next(now);
      if (e.step.action == EstopResetMachine::Action::kCheckMatch) {
        const bool matched = matched_with(writer_.handle(), e.participant);
        e.machine.on_match(now, matched);
        if (!matched) break;
      } else if (e.step.action == EstopResetMachine::Action::kSend) {
        cairn_SafetyReset r{};
        r.robot_id = it->first;
        r.seq = e.step.seq;
        r.issued_ns = now;
        dds::set_text(r.issued_by, e.machine.request().issued_by);
        r.remote_stops_seen = e.remote_stops;
        if (writer_.write(r)) {
          e.machine.on_sent(now);
        } else {
          e.machine.on_send_failed(dds_strretcode(writer_.last_error()));
        }
      } else {
        break;  // waiting for a status, or done
      }
    }
    if (e.machine.done()) {
      done.emplace_back(e.id, e.machine.result());
      it = running_.erase(it);
    } else {
      ++it;
    }
  }
  return done;
}

std::vector<std::pair<std::uint64_t, EstopResetResult>> EstopResetNode::cancel_all(const std::string& why) {
  std::vector<std::pair<std::uint64_t, EstopResetResult>> out;
  for (auto& [robot, e] : running_) {
    EstopResetResult r = e.machine.result();
    r.outcome = EstopResetOutcome::kUnconfirmed;
    r.message = "robot " + std::to_string(robot) + ": " + why;
    out.emplace_back(e.id, std::move(r));
  }
  running_.clear();
  return out;
}

EstopResetResult reset_estop(const dds::Participant& pp, const EstopResetRequest& req) {
  auto& clock = MonotonicClock::instance();
  dds::Topic<cairn_RobotStatus> status_topic(pp);
  dds::Reader<cairn_RobotStatus> status(pp, status_topic, dds::state_qos(4));
  EstopResetNode node(pp, 1);
  std::string why;
  node.start(0, req, clock.now(), &why);  // the node is new: it cannot refuse
  for (;;) {
    status.take([&](const cairn_RobotStatus& s, const dds_sample_info_t& info) { node.on_status(status.handle(), s, info, clock.now()); });
    for (const auto& [id, result] : node.poll(clock.now())) return result;
    // A status wakes us; an unmatched writer is checked again after 10 ms.
    status.wait(node.matching() ? 10 * kNanosPerMilli : 100 * kNanosPerMilli);
  }
}

}  // namespace cairn::base
