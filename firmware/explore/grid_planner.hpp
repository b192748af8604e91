// A path on the classified global map from the robot to its assigned cell (issue 15 item 3,
// first slice): Dijkstra, 8-connected, over clear cells, obstacle and unknown cells never
// entered; clear cells within the robot's radius of an obstacle (the bidder's inflation)
// are entered only on the way out of the start's inflated patch (at a penalty), so a robot
// that drifted close to a wall can still leave it, or as the goal cell itself.
// Pure computation, buffers sized from max_cells at construction (docs/explore.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/occupancy_grid.hpp"
#include "common/se2.hpp"

namespace cairn::explore {

struct GridPlannerConfig {
  std::size_t max_cells = 0;           // the largest map accepted; sizes every buffer
  double robot_radius_m = 0.30;        // inflation, as FrontierBidderConfig::robot_radius_m
  double inflated_cost_factor = 10.0;  // a step in the start's inflated patch costs this many times more (>= 1)
  double clearance_margin_m = 0.15;    // cells within radius + margin of an obstacle cost more ...
  double near_wall_cost_factor = 3.0;  // ... this many times (>= 1): paths keep to the middle
  double goal_tolerance_m = 0.45;      // goal cell unreachable: the reachable clear cell nearest it, this close
  double waypoint_spacing_m = 0.30;    // the cell path is thinned to waypoints about this far apart
};

enum class PlanStatus : std::uint8_t { kOk, kBadMap, kMapTooLarge, kStartOutsideMap, kGoalOutsideMap, kNoPath };

const char* to_string(PlanStatus s);

/// `c` with max_cells set (a map size known only where the planner is built).
inline GridPlannerConfig sized(GridPlannerConfig c, std::size_t max_cells) {
  c.max_cells = max_cells;
  return c;
}

class GridPlanner {
 public:
  /// Throws std::invalid_argument naming the offending parameter.
  explicit GridPlanner(const GridPlannerConfig& config);

  /// On kOk, *path holds waypoints (cell centres, global frame) from the first step after
  /// the start to the goal's cell centre when that cell is clear and reachable, else to the
  /// reachable clear cell nearest the goal within goal_tolerance_m (a frontier cell may have
  /// turned obstacle or inflated on a newer map); otherwise it is empty. The start cell is always expanded
  /// (whatever its class). Allocates only to grow *path beyond its capacity.
  PlanStatus plan(const GridGeometry& g, const Cell* cells, Vec2 start, Vec2 goal, std::vector<Vec2>* path);

  /// Cells settled by the last plan() (its work).
  std::size_t settled() const { return settled_; }

 private:
  void mark_inflated(const GridGeometry& g, const Cell* cells);
  void push_or_decrease(std::uint32_t cell);
  std::uint32_t pop();
  void sift_up(std::size_t k);
  void sift_down(std::size_t k);

  GridPlannerConfig config_;
  std::vector<std::uint8_t> flags_;
  std::vector<float> wall_d2_;  // inflated cells: squared distance (cells²) to the nearest obstacle
  std::vector<double> cost_;
  std::vector<std::uint32_t> parent_;
  std::vector<std::uint32_t> heap_, heap_pos_;
  std::vector<std::uint32_t> cells_path_;  // goal back to start, reused
  std::size_t heap_size_ = 0, settled_ = 0;
};

}  // namespace cairn::explore
