// The cells under the robot's disc, shared by the bidder and the planner. They are free
// whatever the map says: the robot stands on them. The map often leaves them unknown: a
// laser mounted ahead of the robot's centre never sees the cells between the centre and
// the mount (0.2 m, one to two 0.15 m cells), so a robot that has not moved yet would find
// no way out of its own cell, bid nothing and so end exploration at its first bid. Obstacle
// cells under the disc stay obstacles (the map disagrees with the pose; nothing is
// invented). Bounded by the disc ((2⌈r/res⌉ + 1)² cells); no allocation.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "common/occupancy_grid.hpp"
#include "common/se2.hpp"

namespace cairn::explore {

/// Calls on_cell(index) for every non-obstacle cell whose centre is within `radius_m` of
/// `at`, and for the cell containing `at` (whatever the radius).
template <typename OnCell>  // void(std::size_t cell_index)
void for_each_footprint_cell(const GridGeometry& g, const Cell* cells, Vec2 at, double radius_m, OnCell&& on_cell) {
  int ci = 0, cj = 0;
  if (!g.cell_of(at.x(), at.y(), &ci, &cj)) return;
  // In double, clamped to the map: a tiny resolution from the network must not overflow.
  const double reach_cells = std::ceil(std::max(radius_m, 0.0) / g.resolution) + 1;
  const int reach = static_cast<int>(std::min(reach_cells, static_cast<double>(std::max(g.width, g.height))));
  const double r2 = radius_m * radius_m + 1e-9;  // a centre exactly on the circle is in
  for (int j = std::max(cj - reach, 0); j <= std::min(cj + reach, g.height - 1); ++j)
    for (int i = std::max(ci - reach, 0); i <= std::min(ci + reach, g.width - 1); ++i) {
      const std::size_t k = g.index(i, j);
      if (cells[k] == Cell::kObstacle) continue;
      if ((i == ci && j == cj) || (g.center(i, j) - at).squaredNorm() <= r2) on_cell(k);
    }
}

}  // namespace cairn::explore
