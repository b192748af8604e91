// The executive's checks of an operator's VisitRequest before the allocator sees it
// (ExploreNode takes requests from DDS; the network fuzzer calls the same checks).
#pragma once

#include <cmath>
#include <optional>

#include "common/messages.hpp"
#include "common/occupancy_grid.hpp"

namespace cairn::base {

/// Why a visit request is or is not passed to the allocator.
enum class VisitVerdict { kAccepted, kNotFinite, kTooFar, kNotLocalised, kRobotLost, kNotMapped, kInObstacle };

inline const char* visit_verdict_text(VisitVerdict v) {
  switch (v) {
    case VisitVerdict::kAccepted: return "accepted";
    case VisitVerdict::kNotFinite: return "target not finite";
    case VisitVerdict::kTooFar: return "target farther than 10 km from the origin";
    case VisitVerdict::kNotLocalised: return "robot not localised by the fusion";
    case VisitVerdict::kRobotLost: return "robot lost or never heard";
    case VisitVerdict::kNotMapped: return "target not mapped yet (unknown on the central map: robots plan over clear cells)";
    case VisitVerdict::kInObstacle: return "target is an obstacle on the central map";
  }
  return "unknown";
}

/// A visit target farther than this from the global origin (m) is refused: no building is
/// that large, and a planner must never be asked to size a grid for it.
inline constexpr double kMaxVisitDistanceM = 10'000;

/// The checks before the allocator (whose own refusal, a lost robot, is kRobotLost).
/// `target_cell`: the central map's class at the target (target_cell_of); nullopt when
/// the base keeps no map, and then not checked. A target the robot could never plan to
/// is refused at once instead of failing when its robot reports itself stuck.
inline VisitVerdict check_visit(const msg::VisitRequest& v, bool robot_localised,
                                std::optional<Cell> target_cell = std::nullopt) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y)) return VisitVerdict::kNotFinite;
  if (std::hypot(v.x, v.y) > kMaxVisitDistanceM) return VisitVerdict::kTooFar;
  if (!robot_localised) return VisitVerdict::kNotLocalised;
  if (target_cell == Cell::kUnknown) return VisitVerdict::kNotMapped;
  if (target_cell == Cell::kObstacle) return VisitVerdict::kInObstacle;
  return VisitVerdict::kAccepted;
}

/// The class of the cell holding (x, y): unknown outside the grid or for a non-finite point.
template <class ClassifyFn>  // Cell(int i, int j), called only for a cell inside `g`
Cell target_cell_of(const GridGeometry& g, double x, double y, ClassifyFn&& classify) {
  int i = 0, j = 0;
  return g.cell_of(x, y, &i, &j) ? classify(i, j) : Cell::kUnknown;
}

}  // namespace cairn::base
