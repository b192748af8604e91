// The band along the walls of a classified map, shared by the bidder's and the planner's
// inflation: visits every cell within `reach_cells` of an obstacle cell's square with its
// squared distance (cells²) from the cell's centre to that square. Only obstacle cells
// with a non-obstacle 4-neighbour are walked: the nearest obstacle point of any
// non-obstacle cell lies on such a cell's edge. A cell near several obstacles is visited
// once per obstacle (the caller keeps the minimum). Bounded by the map and the reach; no
// allocation.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "common/occupancy_grid.hpp"

namespace cairn::explore {

template <typename OnCell>  // void(std::size_t cell_index, double d2_cells)
void for_each_cell_near_walls(const GridGeometry& g, const Cell* cells, double reach_cells, OnCell&& on_cell) {
  constexpr int kDi4[4] = {1, -1, 0, 0};
  constexpr int kDj4[4] = {0, 0, 1, -1};
  const int reach = static_cast<int>(std::ceil(reach_cells + 0.5));
  for (int j = 0; j < g.height; ++j)
    for (int i = 0; i < g.width; ++i) {
      if (cells[g.index(i, j)] != Cell::kObstacle) continue;
      bool boundary = false;
      for (int d = 0; d < 4 && !boundary; ++d)
        boundary = g.contains(i + kDi4[d], j + kDj4[d]) && cells[g.index(i + kDi4[d], j + kDj4[d])] != Cell::kObstacle;
      if (!boundary) continue;
      for (int dj = std::max(-reach, -j); dj <= std::min(reach, g.height - 1 - j); ++dj)
        for (int di = std::max(-reach, -i); di <= std::min(reach, g.width - 1 - i); ++di) {
          const double dx = std::max(std::abs(di) - 0.5, 0.0), dy = std::max(std::abs(dj) - 0.5, 0.0);
          on_cell(g.index(i + di, j + dj), dx * dx + dy * dy);
        }
    }
}

}  // namespace cairn::explore
