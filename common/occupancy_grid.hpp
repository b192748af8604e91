// A classified occupancy grid: its geometry and its three cell classes (obstacle / clear /
// unknown, the exploration paper's classes). Shared by the base's central mapper, its
// exporters and tools, and the robots' frontier bids, so both sides read one map the same
// way. Pure data, no I/O.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/se2.hpp"

namespace cairn {

/// A rectangular grid of square cells. Cell (i, j) covers
/// [origin_x + i·res, origin_x + (i+1)·res) × [origin_y + j·res, origin_y + (j+1)·res):
/// i grows with x (columns), j with y (rows); (origin_x, origin_y) is the outer corner of
/// cell (0, 0), the lower-left corner of the map (ROS map_server's `origin`).
struct GridGeometry {
  double resolution = 0.15;
  double origin_x = 0, origin_y = 0;
  int width = 0, height = 0;

  std::size_t cells() const { return static_cast<std::size_t>(width) * static_cast<std::size_t>(height); }
  bool contains(int i, int j) const { return i >= 0 && j >= 0 && i < width && j < height; }
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(width) + static_cast<std::size_t>(i);
  }
  /// The cell containing world point (x, y); false (and i, j untouched) outside the grid or for NaN.
  bool cell_of(double x, double y, int* i, int* j) const {
    const double fx = std::floor((x - origin_x) / resolution), fy = std::floor((y - origin_y) / resolution);
    if (!(fx >= 0 && fy >= 0 && fx < width && fy < height)) return false;
    *i = static_cast<int>(fx);
    *j = static_cast<int>(fy);
    return true;
  }
  Vec2 center(int i, int j) const { return {origin_x + (i + 0.5) * resolution, origin_y + (j + 0.5) * resolution}; }
  double xmax() const { return origin_x + width * resolution; }
  double ymax() const { return origin_y + height * resolution; }
};

enum class Cell : std::uint8_t { kUnknown = 0, kClear = 1, kObstacle = 2 };

/// MapTile on the wire (IDL TILE_CELLS; common/dds/convert.cpp checks they agree): square
/// tiles of kMapTileSide cells, occupancy 0..100 %, kMapTileUnknown for a cell never seen.
inline constexpr int kMapTileSide = 64;
inline constexpr std::uint8_t kMapTileUnknown = 255;

/// A classified map: one Cell per grid cell, row-major from the lower-left (index()).
struct ClassGrid {
  GridGeometry geometry;
  std::vector<Cell> cells;

  Cell at(int i, int j) const { return cells[geometry.index(i, j)]; }
  Cell& at(int i, int j) { return cells[geometry.index(i, j)]; }
};

}  // namespace cairn
