// A robot's frontier bid (the exploration seed's §4, issue 15 item 1): from a classified
// global map and the robot's global pose, the frontier cells it can reach, the path cost
// to each (one Dijkstra flood fill), the information each may reveal (a flood fill over
// the unknown cells within sensor range), and the best items as a msg::Bid.
// Pure computation: every buffer is sized from the configuration at construction, and
// compute() allocates nothing; its work is bounded by max_cells (docs/explore.md).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/messages.hpp"
#include "common/occupancy_grid.hpp"
#include "common/se2.hpp"

namespace cairn::explore {

struct FrontierBidderConfig {
  std::size_t max_cells = 0;         // the largest map accepted (width × height); sizes every buffer
  double frontier_spacing_m = 0.30;  // kept frontier cells are at least this far apart (centre to centre)
  double robot_radius_m = 0.30;      // obstacle inflation for the path cost
  double sensor_range_m = 4.0;       // nominal range: unknown cells counted within it of the frontier cell
  std::size_t max_items = msg::kMaxBids;  // items per bid, <= msg::kMaxBids
  std::size_t min_gain_cells = 1;    // items expected to reveal fewer unknown cells are not bid
  double gain_per_metre = 40.0;      // ranking exchange rate: cells of gain worth one metre of travel (the base's cells_per_metre)
  // A run of unknown cells at most this long (in cells: floor(wall_gap_m / resolution))
  // between two obstacle cells, along a row, column or diagonal, is taken as wall cells the
  // laser missed: the gain flood does not cross it, so what lies behind a wall or inside a
  // block's outline is not counted as gain. 0 turns the rule off; at most 8 cells are tested.
  double wall_gap_m = 0.30;
  // The area to explore (global frame, m), e.g. the building's outline from its plan: cells
  // whose centre lies outside are neither frontier cells nor gain. The map's grid usually
  // has a margin around the building; without an area, the unknown in that margin, behind
  // the outer walls, counts as gain that no robot can see. Unset: the whole map.
  bool has_area = false;
  double area_min_x = 0, area_min_y = 0, area_max_x = 0, area_max_y = 0;
};

enum class BidStatus : std::uint8_t {
  kOk,                // out holds >= 1 item
  kBadMap,            // no cells, non-positive size or resolution, non-finite origin
  kMapTooLarge,       // width × height > max_cells: refused, nothing touched
  kRobotOutsideMap,   // the pose is not over a cell (or not finite)
  kRobotInObstacle,   // the robot's cell is an obstacle
  kNoFrontier,        // no reachable frontier cell with gain >= min_gain_cells
};

const char* to_string(BidStatus s);

/// `c` with max_cells set (a map size known only where the bidder is built).
inline FrontierBidderConfig sized(FrontierBidderConfig c, std::size_t max_cells) {
  c.max_cells = max_cells;
  return c;
}

/// What the last compute() saw; the unreachable count is what issue 15 asks the base to
/// report instead of chasing frontiers the robot cannot fit through.
struct BidStats {
  std::size_t reached_cells = 0;               // settled by the path-cost flood fill
  std::size_t frontier_cells = 0;              // clear cells with an unknown 4-neighbour
  std::size_t unreachable_frontier_cells = 0;  // of those, not reached (never bid)
  std::size_t unreachable_clusters = 0;        // their 8-connected clusters (all, sent or not)
  std::size_t clusters_dropped = 0;            // beyond msg::kMaxUnreachable: the smallest, counted, not sent
  std::size_t open_cells = 0;                  // reached by the uninflated flood (the kind test)
  std::size_t candidates = 0;                  // reached frontier cells kept by the spacing rule
  std::size_t below_min_gain = 0;              // candidates dropped for too little gain
  std::size_t gain_cells_visited = 0;          // the information-gain floods' total work
  std::size_t wall_gap_cells = 0;              // unknown cells the gain floods did not enter: wall gaps (per flood)
  std::size_t outside_area_cells = 0;          // unknown cells the gain floods did not enter: outside the area (per flood)
};

class FrontierBidder {
 public:
  /// Throws std::invalid_argument naming the offending parameter.
  explicit FrontierBidder(const FrontierBidderConfig& config);

  /// Fills out->n_items and out->items (global frame; robot_id, seq and map_version are the
  /// caller's), and the unreachable frontier clusters (out->n_unreachable, unreachable,
  /// unreachable_dropped; also on kNoFrontier). `cells` holds geometry.cells() classes,
  /// row-major (GridGeometry::index). On any status but kOk and kNoFrontier, both counts
  /// are 0. No heap allocation.
  BidStatus compute(const GridGeometry& geometry, const Cell* cells, const Pose2& robot_global, msg::Bid* out);

  const BidStats& stats() const { return stats_; }
  const FrontierBidderConfig& config() const { return config_; }

 private:
  struct Candidate {
    std::uint32_t cell = 0;
    double cost = 0;
    std::uint32_t gain = 0;
    int igr_i0 = 0, igr_j0 = 0, igr_i1 = 0, igr_j1 = 0;  // inclusive cell bounds
    double utility = 0;
  };

  void mark_blocked(const GridGeometry& g, const Cell* cells);
  void flood_path_cost(const GridGeometry& g, const Cell* cells, std::uint32_t start);
  bool is_frontier(const GridGeometry& g, const Cell* cells, int i, int j) const;
  Cell class_of(const Cell* cells, std::size_t k) const;
  void consider(const GridGeometry& g, const Cell* cells, std::uint32_t cell);
  void measure_gain(const GridGeometry& g, const Cell* cells, Candidate* c);
  bool in_wall_gap(const GridGeometry& g, const Cell* cells, int i, int j) const;
  bool in_area(int i, int j) const { return i >= area_i0_ && i <= area_i1_ && j >= area_j0_ && j <= area_j1_; }
  bool unknown(const Cell* cells, const GridGeometry& g, int i, int j) const {
    return in_area(i, j) && class_of(cells, g.index(i, j)) == Cell::kUnknown;
  }
  void mark_spacing(const GridGeometry& g, std::uint32_t cell);
  void offer(const Candidate& c);
  void flood_open(const GridGeometry& g, const Cell* cells, std::uint32_t start);
  void cluster_unreachable(const GridGeometry& g, msg::Bid* out);

  // The Dijkstra queue: a binary min-heap of cell indices keyed by cost_, with each cell's
  // heap slot in heap_pos_ for decrease-key, so it never holds more than max_cells entries.
  void heap_push_or_decrease(std::uint32_t cell);
  std::uint32_t heap_pop();
  void sift_up(std::size_t k);
  void sift_down(std::size_t k);

  FrontierBidderConfig config_;
  BidStats stats_;
  int area_i0_ = 0, area_i1_ = 0, area_j0_ = 0, area_j1_ = 0;  // the area's cells in this map (inclusive)
  int wall_gap_n_ = 0;  // the longest wall gap in cells on this map (compute() sets it)
  std::vector<std::uint8_t> flags_;        // per cell: kBlocked | kSettled | kNearKept | kFootprint | kOpen | kUnreachable | kClustered
  std::vector<double> cost_;               // path cost (m) from the robot's cell
  std::vector<std::uint32_t> heap_;        // Dijkstra's open set
  std::vector<std::uint32_t> heap_pos_;    // slot in heap_, kNotInHeap when not queued
  std::vector<std::uint32_t> gain_stamp_;  // gain flood: visited when == gain_epoch_
  std::vector<std::uint32_t> gain_queue_;  // gain flood's FIFO; after Dijkstra, the open flood's and the clustering's
  std::size_t heap_size_ = 0;
  std::uint32_t gain_epoch_ = 0;
  std::array<msg::UnreachableCluster, msg::kMaxUnreachable> clusters_{};  // sorted, largest first
  std::array<Candidate, msg::kMaxBids> best_{};  // sorted, best first
  std::size_t n_best_ = 0;
};

}  // namespace cairn::explore
