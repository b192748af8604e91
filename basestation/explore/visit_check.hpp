// The executive's checks of an operator's VisitRequest before the allocator sees it
// (ExploreNode takes requests from DDS; the network fuzzer calls the same checks).
#pragma once

#include <algorithm>
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
    case VisitVerdict::kNotMapped:
      return "no cell within the arrival radius of the target is clear on the central map (not mapped yet: robots "
             "plan over clear cells)";
    case VisitVerdict::kInObstacle: return "target is an obstacle on the central map, with no clear cell within the arrival radius";
  }
  return "unknown";
}

/// A visit target farther than this from the global origin (m) is refused: no building is
/// that large, and a planner must never be asked to size a grid for it.
inline constexpr double kMaxVisitDistanceM = 10'000;

/// The checks before the allocator (whose own refusal, a lost robot, is kRobotLost).
/// `target`: what the central map says of the target (visit_target_class); nullopt when
/// the base keeps no map, and then not checked. A target no robot could arrive at is
/// refused at once instead of failing when its robot reports itself stuck.
inline VisitVerdict check_visit(const msg::VisitRequest& v, bool robot_localised,
                                std::optional<Cell> target = std::nullopt) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y)) return VisitVerdict::kNotFinite;
  if (std::hypot(v.x, v.y) > kMaxVisitDistanceM) return VisitVerdict::kTooFar;
  if (!robot_localised) return VisitVerdict::kNotLocalised;
  if (target == Cell::kUnknown) return VisitVerdict::kNotMapped;
  if (target == Cell::kObstacle) return VisitVerdict::kInObstacle;
  return VisitVerdict::kAccepted;
}

/// What the central map says of a visit target (x, y): kClear when some cell whose centre
/// lies within `arrival_radius` of it is clear (a robot standing there has arrived, and
/// the robots' planners go to the reachable clear cell nearest a goal); otherwise
/// kObstacle when the target's own cell is an obstacle, else kUnknown (also outside the
/// grid or for a non-finite target). `classify(i, j)` is called only inside `g`.
template <class ClassifyFn>
Cell visit_target_class(const GridGeometry& g, double x, double y, double arrival_radius, ClassifyFn&& classify) {
  if (!std::isfinite(x) || !std::isfinite(y) || !(g.resolution > 0)) return Cell::kUnknown;
  // The target's cell, as if the grid were unbounded: a target just outside it may still
  // have clear cells within reach.
  const double fi = std::floor((x - g.origin_x) / g.resolution), fj = std::floor((y - g.origin_y) / g.resolution);
  if (std::abs(fi) > 1e8 || std::abs(fj) > 1e8) return Cell::kUnknown;  // far off the grid: nothing within reach
  const int i0 = static_cast<int>(fi), j0 = static_cast<int>(fj);
  const double reach = std::min(std::ceil(std::max(arrival_radius, 0.0) / g.resolution) + 1, 1e8);
  const int r = static_cast<int>(reach);
  // Only cells of the grid are visited: the work is bounded by the grid, whatever the radius.
  for (int j = std::max(j0 - r, 0); j <= std::min(j0 + r, g.height - 1); ++j) {
    for (int i = std::max(i0 - r, 0); i <= std::min(i0 + r, g.width - 1); ++i) {
      if ((g.center(i, j) - Vec2(x, y)).norm() > arrival_radius) continue;
      if (classify(i, j) == Cell::kClear) return Cell::kClear;
    }
  }
  return g.contains(i0, j0) && classify(i0, j0) == Cell::kObstacle ? Cell::kObstacle : Cell::kUnknown;
}

}  // namespace cairn::base
