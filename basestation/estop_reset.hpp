// The operator's e-stop reset for one robot (`cairn-base --reset-estop ID`), delivered and
// confirmed: SafetyReset is volatile (a robot started later must never act on an old
// reset), so a sample written before the robot's reader is matched is simply lost. With
// several robots on the domain, "some reader matched" is not "this robot's reader
// matched". So: wait for the robot's RobotStatus, wait until the reset writer is matched
// with a reader of that same participant, write, and watch the robot's status leave
// "reset required"; resend (next seq) until it does or the time is up.
// The logic (what to send, when to resend, when it is done) is EstopResetMachine's
// (basestation/estop_reset_machine.hpp); this drives it on the wall clock and DDS.
#pragma once

#include "basestation/estop_reset_machine.hpp"
#include "common/dds/participant.hpp"

namespace cairn::base {

/// Runs the exchange on `pp` (wall clock; it blocks for at most request.timeout).
EstopResetResult reset_estop(const dds::Participant& pp, const EstopResetRequest& request);

}  // namespace cairn::base
