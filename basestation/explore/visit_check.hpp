// The executive's checks of an operator's VisitRequest before the allocator sees it
// (ExploreNode takes requests from DDS; the network fuzzer calls the same checks).
#pragma once

#include <cmath>

#include "common/messages.hpp"

namespace cairn::base {

/// Why a visit request is or is not passed to the allocator.
enum class VisitVerdict { kAccepted, kNotFinite, kTooFar, kNotLocalised, kRobotLost };

inline const char* visit_verdict_text(VisitVerdict v) {
  switch (v) {
    case VisitVerdict::kAccepted: return "accepted";
    case VisitVerdict::kNotFinite: return "target not finite";
    case VisitVerdict::kTooFar: return "target farther than 10 km from the origin";
    case VisitVerdict::kNotLocalised: return "robot not localised by the fusion";
    case VisitVerdict::kRobotLost: return "robot lost or never heard";
  }
  return "unknown";
}

/// A visit target farther than this from the global origin (m) is refused: no building is
/// that large, and a planner must never be asked to size a grid for it.
inline constexpr double kMaxVisitDistanceM = 10'000;

/// The checks before the allocator (whose own refusal, a lost robot, is kRobotLost).
inline VisitVerdict check_visit(const msg::VisitRequest& v, bool robot_localised) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y)) return VisitVerdict::kNotFinite;
  if (std::hypot(v.x, v.y) > kMaxVisitDistanceM) return VisitVerdict::kTooFar;
  if (!robot_localised) return VisitVerdict::kNotLocalised;
  return VisitVerdict::kAccepted;
}

}  // namespace cairn::base
