// The operator's e-stop reset for one robot, delivered and confirmed: SafetyReset is
// volatile (a robot started later must never act on an old reset), so a sample written
// before the robot's reader is matched is simply lost. With several robots on the domain,
// "some reader matched" is not "this robot's reader matched". So: wait for the robot's
// RobotStatus, wait until the reset writer is matched with a reader of that same
// participant, write, and watch the robot's status leave "reset required"; resend (next
// seq) until it does or the time is up. The logic (what to send, when to resend, when it
// is done) is EstopResetMachine's (basestation/estop_reset_machine.hpp); EstopResetNode
// drives such exchanges on DDS without ever blocking (the base's main loop runs the web
// view's resets with it), and reset_estop() runs one to its end (`cairn-base --reset-estop`).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "basestation/estop_reset_machine.hpp"
#include "common/dds/participant.hpp"
#include "common/dds/topic.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

class EstopResetNode {
 public:
  /// At most `max_running` exchanges at once (one per robot).
  explicit EstopResetNode(const dds::Participant& pp, std::size_t max_running = 8);

  /// Starts an exchange (`id`: the caller's, returned with the result). False, with the
  /// reason in *why, when one already runs for that robot or max_running do.
  bool start(std::uint64_t id, const EstopResetRequest& request, Nanos now, std::string* why);
  /// A RobotStatus sample the caller took with `reader` (on this node's participant):
  /// `info` names the participant that wrote it.
  void on_status(dds_entity_t reader, const cairn_RobotStatus& s, const dds_sample_info_t& info, Nanos now);
  /// Advances every exchange at `now` (never waits); returns those that ended, with their ids.
  std::vector<std::pair<std::uint64_t, EstopResetResult>> poll(Nanos now);
  /// Ends every exchange at once, nothing more sent (a remote e-stop was just sent: no reset
  /// asked for before it may go out after it); returns them with `why` as their message.
  std::vector<std::pair<std::uint64_t, EstopResetResult>> cancel_all(const std::string& why);
  bool idle() const { return running_.empty(); }
  /// Some exchange waits for its writer to match (poll again soon, not only on a status).
  bool matching() const;

 private:
  struct Exchange {
    std::uint64_t id;
    EstopResetMachine machine;
    dds_guid_t participant{};  // the one its robot's latest status came from
    EstopResetMachine::Step step;
    // The robot's remote-stop count in the first status this exchange took: every reset it
    // sends carries it, so the robot refuses them once a later remote e-stop latched it.
    bool stops_known = false;
    std::uint32_t remote_stops = 0;
  };
  std::size_t max_running_;
  dds::Topic<cairn_SafetyReset> topic_;
  dds::Writer<cairn_SafetyReset> writer_;
  std::map<std::uint16_t, Exchange> running_;  // by robot
};

/// Runs one exchange on `pp` to its end (wall clock; blocks for at most request.timeout).
EstopResetResult reset_estop(const dds::Participant& pp, const EstopResetRequest& request);

}  // namespace cairn::base
