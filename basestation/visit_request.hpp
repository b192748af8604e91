// The operator's "robot R, visit (x, y)" (`cairn-base --visit R X Y`; any other operator
// front end writes the same topic), delivered and confirmed: VisitRequest is volatile (a base started later
// must never act on an old request), so the tool first waits until a base's reader is
// matched, writes, and watches TaskAssignment for a new GOTO task sending R to (x, y);
// it resends (next seq) until one comes or the time is up. The base refuses a robot it
// has not localised or has lost and a target beyond 10 km (ExploreNode counts them):
// the tool then reports no confirmation.
// The logic (what to send, when to resend, when it is done) is VisitRequestMachine's
// (basestation/visit_request_machine.hpp); this drives it on the wall clock and DDS.
#pragma once

#include "basestation/visit_request_machine.hpp"
#include "common/dds/participant.hpp"

namespace cairn::base {

/// Runs the exchange on `pp` (wall clock; blocks for at most options.timeout).
VisitResult request_visit(const dds::Participant& pp, const VisitRequestOptions& options);

}  // namespace cairn::base
