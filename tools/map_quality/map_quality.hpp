// Map quality against a HIL world's ground truth (issue 14 item 7; docs/mapper.md,
// "Map quality"). The world file is rasterised on the map's own grid:
//   - wall: a cell that a wall segment or a circle's outline (poles, furniture) touches
//     (closed cells: a wall on a cell border marks both cells);
//   - free: a non-wall cell reachable from the start point by a 4-connected flood fill
//     (the reachable free space);
//   - other: neither (inside furniture, outside the building).
// Then, over the map's known cells (obstacle or clear):
//   coverage        known cells of the free space / free cells
//   drivable coverage (given a robot radius) known cells of the free space the robot's
//                   body can sweep from the start / such cells (drivable_space.hpp)
//   agreement       (obstacle on wall + clear on free) / known cells
//   false obstacles obstacle on a non-wall cell;  false free: clear on a non-free cell
//   wall offset     distance from each obstacle cell's centre to the nearest true wall
//                   (the world's geometry, not its raster): mean, 95th percentile, max.
#pragma once

#include <string>
#include <vector>

#include "basestation/mapper/grid.hpp"
#include "common/messages.hpp"
#include "hil/world/world.hpp"

namespace cairn::tools {

enum class Truth : std::uint8_t { kOther = 0, kFree = 1, kWall = 2 };

struct TruthGrid {
  mapper::GridGeometry geometry;
  std::vector<Truth> cells;
  Truth at(int i, int j) const { return cells[geometry.index(i, j)]; }
};

/// Throws std::invalid_argument if `start` is outside the grid or in a wall cell.
TruthGrid rasterise(const hil::World& world, const mapper::GridGeometry& geometry, const Vec2& start);

/// Distance from p to the nearest wall segment or circle outline of the world (robots excluded).
double distance_to_wall(const hil::World& world, const Vec2& p);

struct MapQuality {
  double resolution = 0;
  std::size_t free_cells = 0, wall_cells = 0;  // truth
  std::size_t known = 0, obstacle = 0, clear = 0;
  std::size_t known_free = 0;  // known cells in the truth's free space
  std::size_t agree = 0, false_obstacles = 0, false_free = 0;
  double coverage = 0, agreement = 0, false_obstacle_rate = 0, false_free_rate = 0;
  double robot_radius_m = 0;  // 0: no drivable space (the fields below stay 0)
  std::size_t drivable_cells = 0, known_drivable = 0;
  double drivable_coverage = 0;
  double wall_offset_mean_m = 0, wall_offset_p95_m = 0, wall_offset_max_m = 0;
  double wall_offset_mean_cells() const { return wall_offset_mean_m / resolution; }
  double wall_offset_max_cells() const { return wall_offset_max_m / resolution; }
};

/// Start point by default: robot 1's start in the world, else the centre of its bounds.
Vec2 default_start(const hil::World& world);

MapQuality evaluate(const mapper::ClassGrid& map, const hil::World& world, const Vec2& start);

/// The truth a map is scored against, for one world and one map geometry: built once and
/// reused (the drivable space costs a fine raster). robot_radius_m 0: no drivable space.
struct Reference {
  TruthGrid truth;
  std::vector<std::uint8_t> drivable;  // per cell, 1: free and drivable (empty without a radius)
  double robot_radius_m = 0;
};
Reference make_reference(const hil::World& world, const mapper::GridGeometry& geometry, const Vec2& start,
                         double robot_radius_m = 0);
/// Throws std::invalid_argument when the map's geometry is not the reference's.
MapQuality evaluate(const mapper::ClassGrid& map, const Reference& reference, const hil::World& world);

std::string to_text(const MapQuality& q);
std::string to_json(const MapQuality& q);

struct PoseQuality;  // tools/map_quality/pose_quality.hpp

/// Mapped landmarks against the world's poles (the base's global frame is the world's on
/// the HIL bench): each pole is paired with the nearest unpaired landmark within match_m,
/// nearest pairs first.
struct LandmarkQuality {
  std::size_t poles = 0, landmarks = 0, matched = 0;
  std::size_t spurious = 0;  // landmarks paired with no pole
  std::size_t missing = 0;   // poles paired with no landmark (never seen, or too far off)
  double error_mean_m = 0, error_rms_m = 0, error_max_m = 0;  // over the pairs
};
LandmarkQuality evaluate_landmarks(const std::vector<msg::Landmark>& landmarks, const std::vector<Vec2>& poles,
                                   double match_m = 1.0);
std::string to_text(const LandmarkQuality& q);
std::string to_json(const LandmarkQuality& q);
/// The map's JSON with the landmarks' under "landmarks".
std::string to_json(const MapQuality& q, const LandmarkQuality& l);
/// The map's JSON with, when given, the landmarks' under "landmarks" and the robot poses'
/// (tools/map_quality/pose_quality.hpp) under "poses".
std::string to_json(const MapQuality& q, const LandmarkQuality* l, const PoseQuality* p);

/// The truth as a map (wall -> obstacle, free -> clear, other -> unknown): what a
/// perfect mapper would produce.
mapper::ClassGrid truth_as_map(const TruthGrid& truth);

}  // namespace cairn::tools
