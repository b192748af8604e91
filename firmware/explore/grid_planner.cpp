#include "firmware/explore/grid_planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "firmware/explore/footprint.hpp"
#include "firmware/explore/wall_band.hpp"

namespace cairn::explore {

namespace {

constexpr std::uint8_t kWall = 1;      // obstacle or unknown: never entered (except the start)
constexpr std::uint8_t kInflated = 2;  // clear, within the robot's radius of an obstacle
constexpr std::uint8_t kSettled = 4;
constexpr std::uint8_t kNearWall = 8;  // clear, within radius + clearance margin of an obstacle
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr double kEps = 1e-9;

void require(bool ok, const char* parameter, const std::string& rule, double got) {
  if (!ok)
    throw std::invalid_argument(std::string("GridPlanner: ") + parameter + " " + rule + " (got " + std::to_string(got) +
                                ")");
}

}  // namespace

const char* to_string(PlanStatus s) {
  switch (s) {
    case PlanStatus::kOk: return "ok";
    case PlanStatus::kBadMap: return "bad map";
    case PlanStatus::kMapTooLarge: return "map too large";
    case PlanStatus::kStartOutsideMap: return "start outside the map";
    case PlanStatus::kGoalOutsideMap: return "goal outside the map";
    case PlanStatus::kNoPath: return "no path";
  }
  return "?";
}

GridPlanner::GridPlanner(const GridPlannerConfig& c) : config_(c) {
  require(c.max_cells > 0 && c.max_cells < kNone, "max_cells", "must be in [1, 2^32 - 1)", static_cast<double>(c.max_cells));
  require(std::isfinite(c.robot_radius_m) && c.robot_radius_m >= 0, "robot_radius_m", "must be finite and >= 0",
          c.robot_radius_m);
  require(std::isfinite(c.inflated_cost_factor) && c.inflated_cost_factor >= 1, "inflated_cost_factor",
          "must be finite and >= 1", c.inflated_cost_factor);
  require(std::isfinite(c.clearance_margin_m) && c.clearance_margin_m >= 0, "clearance_margin_m",
          "must be finite and >= 0", c.clearance_margin_m);
  require(std::isfinite(c.near_wall_cost_factor) && c.near_wall_cost_factor >= 1, "near_wall_cost_factor",
          "must be finite and >= 1", c.near_wall_cost_factor);
  require(std::isfinite(c.goal_tolerance_m) && c.goal_tolerance_m >= 0, "goal_tolerance_m", "must be finite and >= 0",
          c.goal_tolerance_m);
  require(std::isfinite(c.waypoint_spacing_m) && c.waypoint_spacing_m > 0, "waypoint_spacing_m",
          "must be finite and > 0", c.waypoint_spacing_m);
  flags_.assign(c.max_cells, 0);
  cost_.assign(c.max_cells, 0.0);
  parent_.assign(c.max_cells, kNone);
  wall_d2_.assign(c.max_cells, 0.0f);
  heap_.assign(c.max_cells, 0);
  heap_pos_.assign(c.max_cells, kNone);
  cells_path_.reserve(c.max_cells);
}

// The bidder's inflation rule: a clear cell is inflated when the robot's disc at its centre
// would overlap an obstacle cell's square.
void GridPlanner::mark_inflated(const GridGeometry& g, const Cell* cells) {
  const std::size_t n = g.cells();
  for (std::size_t k = 0; k < n; ++k) flags_[k] = cells[k] == Cell::kClear ? 0 : kWall;
  std::fill_n(wall_d2_.begin(), n, std::numeric_limits<float>::infinity());
  if (config_.robot_radius_m + config_.clearance_margin_m <= 0) return;
  const double rc = config_.robot_radius_m / g.resolution;
  const double rc2 = rc * rc - kEps;
  const double rn = (config_.robot_radius_m + config_.clearance_margin_m) / g.resolution;
  const double rn2 = rn * rn - kEps;
  for_each_cell_near_walls(g, cells, rn, [&](std::size_t k, double d2) {
    if (flags_[k] & kWall) return;
    if (d2 < rc2) {
      flags_[k] |= kInflated;
      wall_d2_[k] = std::min(wall_d2_[k], static_cast<float>(d2));
    } else if (d2 < rn2) {
      flags_[k] |= kNearWall;
    }
  });
}

PlanStatus GridPlanner::plan(const GridGeometry& g, const Cell* cells, Vec2 start, Vec2 goal, std::vector<Vec2>* path) {
  path->clear();
  settled_ = 0;
  if (cells == nullptr || g.width <= 0 || g.height <= 0 || !std::isfinite(g.resolution) || !(g.resolution > 0) ||
      !std::isfinite(g.origin_x) || !std::isfinite(g.origin_y))
    return PlanStatus::kBadMap;
  if (g.cells() > config_.max_cells) return PlanStatus::kMapTooLarge;
  int si = 0, sj = 0, gi = 0, gj = 0;
  if (!g.cell_of(start.x(), start.y(), &si, &sj)) return PlanStatus::kStartOutsideMap;
  if (!g.cell_of(goal.x(), goal.y(), &gi, &gj)) return PlanStatus::kGoalOutsideMap;
  const auto s = static_cast<std::uint32_t>(g.index(si, sj));
  const double tol2 = config_.goal_tolerance_m * config_.goal_tolerance_m + kEps;
  const auto gw = static_cast<std::uint32_t>(g.width);
  auto goal_d2 = [&](std::uint32_t c) {
    return (g.center(static_cast<int>(c % gw), static_cast<int>(c / gw)) - goal).squaredNorm();
  };
  const auto goal_index = static_cast<std::uint32_t>(g.index(gi, gj));
  auto goal_cell = [&](std::uint32_t c) { return c == goal_index && cells[c] == Cell::kClear; };

  mark_inflated(g, cells);
  // The robot's footprint is free (footprint.hpp): its unknown cells are entered.
  for_each_footprint_cell(g, cells, start, config_.robot_radius_m,
                          [&](std::size_t k) { flags_[k] = static_cast<std::uint8_t>(flags_[k] & ~kWall); });
  const std::size_t n = g.cells();
  std::fill_n(cost_.begin(), n, std::numeric_limits<double>::infinity());
  std::fill_n(heap_pos_.begin(), n, kNone);
  heap_size_ = 0;
  cost_[s] = 0;
  parent_[s] = kNone;
  push_or_decrease(s);
  const auto w = static_cast<std::uint32_t>(g.width);
  // The goal's own cell when reached; else the reached clear cell nearest to the goal
  // within the tolerance (the whole reachable area is then flooded).
  std::uint32_t t = kNone, near = kNone;
  double near_d2 = tol2;
  while (heap_size_ > 0) {
    const std::uint32_t c = pop();
    flags_[c] |= kSettled;
    ++settled_;
    if (c != s && goal_cell(c)) {
      t = c;
      break;
    }
    if (c != s && cells[c] == Cell::kClear && goal_d2(c) <= near_d2) {
      near_d2 = goal_d2(c);
      near = c;
    }
    const int i = static_cast<int>(c % w), j = static_cast<int>(c / w);
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if ((di == 0 && dj == 0) || !g.contains(i + di, j + dj)) continue;
        const std::size_t nb = g.index(i + di, j + dj);
        if (flags_[nb] & (kWall | kSettled)) continue;
        // Inflated cells: only on the way out of the start's inflated patch (from the start,
        // or from an inflated cell to one strictly farther from the nearest obstacle: along
        // the band, and so into a gap narrower than the robot, is never a way), or as the goal.
        if ((flags_[nb] & kInflated) && !goal_cell(static_cast<std::uint32_t>(nb)) && c != s &&
            !((flags_[c] & kInflated) && wall_d2_[nb] > wall_d2_[c]))
          continue;
        const bool diag = di != 0 && dj != 0;
        if (diag && ((flags_[g.index(i + di, j)] & kWall) || (flags_[g.index(i, j + dj)] & kWall))) continue;
        double step = diag ? g.resolution * std::numbers::sqrt2 : g.resolution;
        if (flags_[nb] & kInflated) step *= config_.inflated_cost_factor;
        else if (flags_[nb] & kNearWall) step *= config_.near_wall_cost_factor;
        const double nc = cost_[c] + step;
        if (nc < cost_[nb]) {
          cost_[nb] = nc;
          parent_[nb] = c;
          push_or_decrease(static_cast<std::uint32_t>(nb));
        }
      }
  }
  if (t == kNone) t = near;
  if (t == kNone) return PlanStatus::kNoPath;
  cells_path_.clear();
  for (std::uint32_t c = t; c != s; c = parent_[c]) cells_path_.push_back(c);
  // Thinned: every k-th cell from the start's side, and always the goal.
  const auto every = static_cast<std::size_t>(std::max(1.0, std::floor(config_.waypoint_spacing_m / g.resolution)));
  const std::size_t m = cells_path_.size();
  for (std::size_t k = 1; k <= m; ++k) {
    if (k % every != 0 && k != m) continue;
    const std::uint32_t c = cells_path_[m - k];
    path->push_back(g.center(static_cast<int>(c % w), static_cast<int>(c / w)));
  }
  return PlanStatus::kOk;
}

void GridPlanner::push_or_decrease(std::uint32_t cell) {
  if (heap_pos_[cell] == kNone) {
    heap_[heap_size_] = cell;
    heap_pos_[cell] = static_cast<std::uint32_t>(heap_size_);
    ++heap_size_;
  }
  sift_up(heap_pos_[cell]);
}

std::uint32_t GridPlanner::pop() {
  const std::uint32_t top = heap_[0];
  heap_pos_[top] = kNone;
  --heap_size_;
  if (heap_size_ > 0) {
    heap_[0] = heap_[heap_size_];
    heap_pos_[heap_[0]] = 0;
    sift_down(0);
  }
  return top;
}

void GridPlanner::sift_up(std::size_t k) {
  while (k > 0) {
    const std::size_t p = (k - 1) / 2;
    if (!(cost_[heap_[k]] < cost_[heap_[p]])) break;
    std::swap(heap_[k], heap_[p]);
    heap_pos_[heap_[k]] = static_cast<std::uint32_t>(k);
    heap_pos_[heap_[p]] = static_cast<std::uint32_t>(p);
    k = p;
  }
}

void GridPlanner::sift_down(std::size_t k) {
  while (true) {
    const std::size_t l = 2 * k + 1, r = l + 1;
    std::size_t m = k;
    if (l < heap_size_ && cost_[heap_[l]] < cost_[heap_[m]]) m = l;
    if (r < heap_size_ && cost_[heap_[r]] < cost_[heap_[m]]) m = r;
    if (m == k) break;
    std::swap(heap_[k], heap_[m]);
    heap_pos_[heap_[k]] = static_cast<std::uint32_t>(k);
    heap_pos_[heap_[m]] = static_cast<std::uint32_t>(m);
    k = m;
  }
}

}  // namespace cairn::explore
