// The operator's "robot R, visit (x, y)" (`cairn-base --visit R X Y`; any other operator
// front end writes the same topic), delivered and confirmed: VisitRequest is volatile (a base started later
// must never act on an old request), so the tool first waits until a base's reader is
// matched, writes, and watches TaskAssignment for a new GOTO task sending R to (x, y);
// it resends (next seq) until one comes or the time is up. The base refuses a robot it
// has not localised or has lost and a target beyond 10 km (ExploreNode counts them):
// the tool then reports no confirmation.
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"
#include "common/dds/participant.hpp"
#include "common/se2.hpp"

namespace cairn::base {

struct VisitRequestOptions {
  std::uint16_t robot = 0;
  Vec2 target = Vec2::Zero();  // global frame, m
  std::string issued_by;       // VisitRequest.issued_by, e.g. "cairn-base base1"
  Nanos timeout = 10 * kNanosPerSecond;        // for the whole exchange
  Nanos confirm_wait = 3 * kNanosPerSecond;    // per try: the base polls every 50 ms; margin for a loaded machine
  Nanos history_wait = 300 * kNanosPerMilli;   // to receive the robot's current (latched) task before writing
};

enum class VisitOutcome {
  kConfirmed,    // a new GOTO task for the robot to the target
  kNoBase,       // no reader of VisitRequest matched within the timeout
  kUnconfirmed,  // sent, but no such task came (refused by the base, or exploration is off)
};
const char* visit_outcome_name(VisitOutcome o);

struct VisitResult {
  VisitOutcome outcome = VisitOutcome::kNoBase;
  int sent = 0;               // VisitRequest samples written
  std::uint32_t task_id = 0;  // the confirming task
  std::string message;        // one line for the operator
  bool ok() const { return outcome == VisitOutcome::kConfirmed; }
};

/// Runs the exchange on `pp` (wall clock; blocks for at most options.timeout).
VisitResult request_visit(const dds::Participant& pp, const VisitRequestOptions& options);

}  // namespace cairn::base
