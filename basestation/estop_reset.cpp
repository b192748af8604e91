#include "basestation/estop_reset.hpp"

#include <array>
#include <cstring>

#include "common/dds/qos.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

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
  const Nanos deadline = clock.now() + req.timeout;
  const std::string who = "robot " + std::to_string(req.robot);
  dds::Topic<cairn_RobotStatus> status_topic(pp);
  dds::Reader<cairn_RobotStatus> status(pp, status_topic, dds::state_qos(4));
  dds::Topic<cairn_SafetyReset> reset_topic(pp);
  dds::Writer<cairn_SafetyReset> writer(pp, reset_topic, dds::state_qos(4));

  EstopResetResult res;
  bool heard = false;
  dds_guid_t robot_participant{};
  Nanos heard_at = 0;
  // Takes the robot's status samples; true when one arrived.
  auto poll_status = [&](Nanos until) {
    bool got = false;
    while (!got) {
      status.take([&](const cairn_RobotStatus& s, const dds_sample_info_t& info) {
        if (s.robot_id != req.robot) return;
        dds_guid_t p{};
        if (!publisher_participant(status.handle(), info.publication_handle, &p)) return;
        robot_participant = p;
        res.last_reason = static_cast<StopReason>(s.stop_reason);
        res.last_text.assign(s.stop_text, strnlen(s.stop_text, sizeof s.stop_text));
        heard = got = true;
        heard_at = clock.now();
      });
      const Nanos now = clock.now();
      if (got || now >= until) break;
      status.wait(std::min<Nanos>(until - now, 100 * kNanosPerMilli));
    }
    return got;
  };
  auto finish = [&](EstopResetOutcome o, const std::string& why) {
    res.outcome = o;
    res.message = who + ": " + why;
    return res;
  };
  auto reason_line = [&] {
    return "stop reason " + std::to_string(static_cast<int>(res.last_reason)) + " (" +
           (res.last_text.empty() ? stop_reason_text(res.last_reason) : res.last_text) + ")";
  };

  if (!poll_status(deadline)) {
    return finish(EstopResetOutcome::kNoRobot, "no RobotStatus on this DDS domain within " +
                                                   std::to_string(nanos_to_seconds(req.timeout)) + " s: is it running, on this domain?");
  }
  if (static_cast<std::uint8_t>(res.last_reason) > static_cast<std::uint8_t>(StopReason::kResetRequired)) {
    return finish(EstopResetOutcome::kCannotReset, reason_line() + ": a stop reason this base does not know; nothing sent");
  }
  if (res.last_reason != StopReason::kResetRequired) {
    if (stop_reason_masks_latch(res.last_reason)) {
      return finish(EstopResetOutcome::kCannotReset,
                    reason_line() + ": a reset is accepted only with the e-stop released, its input fresh and the "
                                    "wheel feedback flowing; nothing sent");
    }
    return finish(EstopResetOutcome::kNotLatched, "not latched, " + reason_line() + "; nothing sent");
  }
  // Its status came from a participant whose reset reader must be matched with our writer.
  while (!matched_with(writer.handle(), robot_participant)) {
    if (clock.now() >= deadline) {
      return finish(EstopResetOutcome::kNotMatched, "its status arrives but its SafetyReset reader never matched ours within " +
                                                        std::to_string(nanos_to_seconds(req.timeout)) + " s");
    }
    dds_sleepfor(DDS_MSECS(10));
  }
  while (clock.now() < deadline) {
    cairn_SafetyReset r{};
    r.robot_id = req.robot;
    r.seq = static_cast<std::uint32_t>(res.sent + 1);
    r.issued_ns = clock.now();
    dds::set_text(r.issued_by, req.issued_by);
    const Nanos sent_at = clock.now();
    if (!writer.write(r)) {
      return finish(EstopResetOutcome::kUnconfirmed,
                    std::string("writing the reset failed: ") + dds_strretcode(writer.last_error()));
    }
    ++res.sent;
    dds_wait_for_acks(writer.handle(), std::max<Nanos>(0, std::min(deadline - clock.now(), 2 * kNanosPerSecond)));
    // A status written before the robot took the reset may still say 8: wait for a later one.
    const Nanos try_end = std::min(deadline, sent_at + req.confirm_wait);
    while (clock.now() < try_end && poll_status(try_end)) {
      if (heard_at <= sent_at) continue;
      if (res.last_reason == StopReason::kResetRequired) continue;
      if (stop_reason_masks_latch(res.last_reason) ||
          static_cast<std::uint8_t>(res.last_reason) > static_cast<std::uint8_t>(StopReason::kResetRequired)) {
        return finish(EstopResetOutcome::kCannotReset, "reset sent, but now " + reason_line());
      }
      return finish(EstopResetOutcome::kConfirmed, "reset accepted after " + std::to_string(res.sent) + " send(s), now " +
                                                       reason_line());
    }
  }
  return finish(EstopResetOutcome::kUnconfirmed, "sent " + std::to_string(res.sent) +
                                                     " reset(s), acknowledged, but its status still says " + reason_line());
}

}  // namespace cairn::base
