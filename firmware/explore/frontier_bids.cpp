#include "firmware/explore/frontier_bids.hpp"

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

constexpr std::uint8_t kBlocked = 1;   // not traversable: not clear, or within the robot's radius of an obstacle
constexpr std::uint8_t kSettled = 2;   // its path cost is final (reached)
constexpr std::uint8_t kNearKept = 4;  // closer than frontier_spacing_m to a kept frontier cell
constexpr std::uint8_t kFootprint = 8;  // under the robot's disc: free, whatever the map says (footprint.hpp)
constexpr std::uint8_t kOpen = 16;        // reached from the robot over clear cells, without inflation
constexpr std::uint8_t kUnreachable = 32;  // an unreachable frontier cell
constexpr std::uint8_t kClustered = 64;    // an unreachable frontier cell already in a cluster
constexpr std::uint32_t kNotInHeap = std::numeric_limits<std::uint32_t>::max();
constexpr double kEps = 1e-9;  // in cells²: a distance exactly on a limit counts as on the limit
constexpr double kMaxWallGapM = 1.0;  // a wider gap is an opening
constexpr int kMaxWallGapCells = 8;   // bounds the wall-gap test's work per cell: 4 · 2 · 8 reads

constexpr int kDi4[4] = {1, -1, 0, 0};
constexpr int kDj4[4] = {0, 0, 1, -1};

void require(bool ok, const char* parameter, const std::string& rule, double got) {
  if (!ok)
    throw std::invalid_argument(std::string("FrontierBidder: ") + parameter + " " + rule + " (got " +
                                std::to_string(got) + ")");
}

}  // namespace

const char* to_string(BidStatus s) {
  switch (s) {
    case BidStatus::kOk: return "ok";
    case BidStatus::kBadMap: return "bad map";
    case BidStatus::kMapTooLarge: return "map too large";
    case BidStatus::kRobotOutsideMap: return "robot outside the map";
    case BidStatus::kRobotInObstacle: return "robot in an obstacle";
    case BidStatus::kNoFrontier: return "no frontier";
  }
  return "?";
}

FrontierBidder::FrontierBidder(const FrontierBidderConfig& config) : config_(config) {
  const auto& c = config;
  require(c.max_cells > 0 && c.max_cells < kNotInHeap, "max_cells", "must be in [1, 2^32 - 1)",
          static_cast<double>(c.max_cells));
  require(std::isfinite(c.frontier_spacing_m) && c.frontier_spacing_m >= 0, "frontier_spacing_m",
          "must be finite and >= 0", c.frontier_spacing_m);
  require(std::isfinite(c.robot_radius_m) && c.robot_radius_m >= 0, "robot_radius_m", "must be finite and >= 0",
          c.robot_radius_m);
  require(std::isfinite(c.sensor_range_m) && c.sensor_range_m > 0, "sensor_range_m", "must be finite and > 0",
          c.sensor_range_m);
  require(c.max_items >= 1 && c.max_items <= msg::kMaxBids, "max_items",
          "must be in [1, " + std::to_string(msg::kMaxBids) + "] (msg::kMaxBids)", static_cast<double>(c.max_items));
  require(c.min_gain_cells >= 1, "min_gain_cells", "must be >= 1", static_cast<double>(c.min_gain_cells));
  require(std::isfinite(c.gain_per_metre) && c.gain_per_metre >= 0, "gain_per_metre", "must be finite and >= 0",
          c.gain_per_metre);
  require(std::isfinite(c.wall_gap_m) && c.wall_gap_m >= 0 && c.wall_gap_m <= kMaxWallGapM, "wall_gap_m",
          "must be finite and in [0, " + std::to_string(kMaxWallGapM) + "]", c.wall_gap_m);
  if (c.has_area)
    require(std::isfinite(c.area_min_x) && std::isfinite(c.area_min_y) && std::isfinite(c.area_max_x) &&
                std::isfinite(c.area_max_y) && c.area_min_x < c.area_max_x && c.area_min_y < c.area_max_y,
            "area", "must be finite with min < max", c.area_max_x - c.area_min_x);
  flags_.assign(c.max_cells, 0);
  cost_.assign(c.max_cells, 0.0);
  heap_.assign(c.max_cells, 0);
  heap_pos_.assign(c.max_cells, kNotInHeap);
  gain_stamp_.assign(c.max_cells, 0);
  gain_queue_.assign(c.max_cells, 0);
}

BidStatus FrontierBidder::compute(const GridGeometry& g, const Cell* cells, const Pose2& robot, msg::Bid* out) {
  out->n_items = 0;
  out->n_unreachable = 0;
  out->unreachable_dropped = 0;
  stats_ = {};
  n_best_ = 0;
  if (cells == nullptr || g.width <= 0 || g.height <= 0 || !std::isfinite(g.resolution) || !(g.resolution > 0) ||
      !std::isfinite(g.origin_x) || !std::isfinite(g.origin_y))
    return BidStatus::kBadMap;
  if (g.cells() > config_.max_cells) return BidStatus::kMapTooLarge;
  int ri = 0, rj = 0;
  if (!g.cell_of(robot.x, robot.y, &ri, &rj)) return BidStatus::kRobotOutsideMap;
  const auto start = static_cast<std::uint32_t>(g.index(ri, rj));
  if (cells[start] == Cell::kObstacle) return BidStatus::kRobotInObstacle;

  // At most kMaxWallGapCells: the wall-gap test's work per cell stays bounded whatever the
  // map's resolution.
  wall_gap_n_ = std::min(kMaxWallGapCells, static_cast<int>(std::floor(config_.wall_gap_m / g.resolution + 1e-9)));
  area_i0_ = area_j0_ = 0;
  area_i1_ = g.width - 1;
  area_j1_ = g.height - 1;
  if (config_.has_area) {  // the cells whose centre lies inside (possibly none)
    // Clamped in double before the cast: a far-away area must not overflow an int.
    auto first = [&](double lo, double origin, int size) {
      return static_cast<int>(std::clamp(std::ceil((lo - origin) / g.resolution - 0.5), -1.0, static_cast<double>(size)));
    };
    auto last = [&](double hi, double origin, int size) {
      return static_cast<int>(std::clamp(std::floor((hi - origin) / g.resolution - 0.5), -1.0, static_cast<double>(size)));
    };
    area_i0_ = std::max(area_i0_, first(config_.area_min_x, g.origin_x, g.width));
    area_j0_ = std::max(area_j0_, first(config_.area_min_y, g.origin_y, g.height));
    area_i1_ = std::min(area_i1_, last(config_.area_max_x, g.origin_x, g.width));
    area_j1_ = std::min(area_j1_, last(config_.area_max_y, g.origin_y, g.height));
  }
  mark_blocked(g, cells);
  for_each_footprint_cell(g, cells, Vec2(robot.x, robot.y), config_.robot_radius_m,
                          [&](std::size_t k) { flags_[k] = static_cast<std::uint8_t>((flags_[k] & ~kBlocked) | kFootprint); });
  flood_path_cost(g, cells, start);

  for (int j = 0; j < g.height; ++j)
    for (int i = 0; i < g.width; ++i) {
      if (!is_frontier(g, cells, i, j)) continue;
      ++stats_.frontier_cells;
      const std::size_t k = g.index(i, j);
      if (!(flags_[k] & kSettled)) {
        ++stats_.unreachable_frontier_cells;
        flags_[k] |= kUnreachable;
      }
    }
  if (stats_.unreachable_frontier_cells > 0) {
    flood_open(g, cells, start);
    cluster_unreachable(g, out);
  }

  for (std::size_t k = 0; k < n_best_; ++k) {
    const Candidate& c = best_[k];
    const int i = static_cast<int>(c.cell % static_cast<std::uint32_t>(g.width));
    const int j = static_cast<int>(c.cell / static_cast<std::uint32_t>(g.width));
    const Vec2 p = g.center(i, j);
    msg::BidItem& item = out->items[k];
    item.x = p.x();
    item.y = p.y();
    item.gain = c.gain;
    item.cost = c.cost;
    item.igr_min_x = g.origin_x + c.igr_i0 * g.resolution;
    item.igr_min_y = g.origin_y + c.igr_j0 * g.resolution;
    item.igr_max_x = g.origin_x + (c.igr_i1 + 1) * g.resolution;
    item.igr_max_y = g.origin_y + (c.igr_j1 + 1) * g.resolution;
  }
  out->n_items = static_cast<std::uint16_t>(n_best_);
  return n_best_ > 0 ? BidStatus::kOk : BidStatus::kNoFrontier;
}

// Breadth-first from the robot's cell over clear cells (and the footprint), 4-connected,
// ignoring the inflation: what the robot could reach if its body were a point. An
// unreachable frontier cell this reaches is behind a gap too narrow for the robot.
// 4-connected: two obstacle cells touching at a corner leave no gap at all.
void FrontierBidder::flood_open(const GridGeometry& g, const Cell* cells, std::uint32_t start) {
  const auto w = static_cast<std::uint32_t>(g.width);
  std::size_t head = 0, tail = 0;
  flags_[start] |= kOpen;
  gain_queue_[tail++] = start;
  while (head < tail) {
    const std::uint32_t c = gain_queue_[head++];
    const int i = static_cast<int>(c % w), j = static_cast<int>(c / w);
    for (int d = 0; d < 4; ++d) {
      if (!g.contains(i + kDi4[d], j + kDj4[d])) continue;
      const std::size_t nb = g.index(i + kDi4[d], j + kDj4[d]);
      if ((flags_[nb] & kOpen) || class_of(cells, nb) != Cell::kClear) continue;
      flags_[nb] |= kOpen;
      gain_queue_[tail++] = static_cast<std::uint32_t>(nb);
    }
  }
  stats_.open_cells = tail;
}

// The unreachable frontier cells' 8-connected clusters, in scan order; the
// msg::kMaxUnreachable largest are kept (ties: the one found first), the rest counted.
// A cluster is too narrow when one of its cells was reached by the open flood.
void FrontierBidder::cluster_unreachable(const GridGeometry& g, msg::Bid* out) {
  const auto w = static_cast<std::uint32_t>(g.width);
  std::size_t kept = 0;
  const std::size_t n = g.cells();
  for (std::size_t seed = 0; seed < n; ++seed) {
    if ((flags_[seed] & (kUnreachable | kClustered)) != kUnreachable) continue;
    std::size_t head = 0, tail = 0;
    flags_[seed] |= kClustered;
    gain_queue_[tail++] = static_cast<std::uint32_t>(seed);
    double sum_i = 0, sum_j = 0;
    int i0 = std::numeric_limits<int>::max(), j0 = i0, i1 = std::numeric_limits<int>::min(), j1 = i1;
    bool open = false;
    while (head < tail) {
      const std::uint32_t c = gain_queue_[head++];
      const int i = static_cast<int>(c % w), j = static_cast<int>(c / w);
      sum_i += i;
      sum_j += j;
      i0 = std::min(i0, i), j0 = std::min(j0, j), i1 = std::max(i1, i), j1 = std::max(j1, j);
      open = open || (flags_[c] & kOpen);
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          if ((di == 0 && dj == 0) || !g.contains(i + di, j + dj)) continue;
          const std::size_t nb = g.index(i + di, j + dj);
          if ((flags_[nb] & (kUnreachable | kClustered)) != kUnreachable) continue;
          flags_[nb] |= kClustered;
          gain_queue_[tail++] = static_cast<std::uint32_t>(nb);
        }
    }
    ++stats_.unreachable_clusters;
    msg::UnreachableCluster u;
    const double count = static_cast<double>(tail);
    u.x = g.origin_x + (sum_i / count + 0.5) * g.resolution;
    u.y = g.origin_y + (sum_j / count + 0.5) * g.resolution;
    u.min_x = g.origin_x + i0 * g.resolution;
    u.min_y = g.origin_y + j0 * g.resolution;
    u.max_x = g.origin_x + (i1 + 1) * g.resolution;
    u.max_y = g.origin_y + (j1 + 1) * g.resolution;
    u.cells = static_cast<std::uint32_t>(tail);
    u.kind = open ? msg::UnreachableKind::kTooNarrow : msg::UnreachableKind::kDisconnected;
    // Insert, largest first; a full list drops its smallest (or this one).
    std::size_t k = kept;
    if (kept < msg::kMaxUnreachable) {
      ++kept;
    } else if (u.cells > clusters_[kept - 1].cells) {
      k = kept - 1;
      ++stats_.clusters_dropped;
    } else {
      ++stats_.clusters_dropped;
      continue;
    }
    while (k > 0 && u.cells > clusters_[k - 1].cells) {
      clusters_[k] = clusters_[k - 1];
      --k;
    }
    clusters_[k] = u;
  }
  std::copy_n(clusters_.begin(), kept, out->unreachable.begin());
  out->n_unreachable = static_cast<std::uint16_t>(kept);
  out->unreachable_dropped = static_cast<std::uint32_t>(stats_.clusters_dropped);
}

// Inflation: a cell is blocked when the robot's disc at its centre would overlap an
// obstacle cell (distance from the centre to the obstacle's square < radius).
void FrontierBidder::mark_blocked(const GridGeometry& g, const Cell* cells) {
  const std::size_t n = g.cells();
  for (std::size_t k = 0; k < n; ++k) flags_[k] = cells[k] == Cell::kClear ? 0 : kBlocked;
  if (config_.robot_radius_m <= 0) return;
  const double rc = config_.robot_radius_m / g.resolution;
  const double rc2 = rc * rc - kEps;
  for_each_cell_near_walls(g, cells, rc, [&](std::size_t k, double d2) {
    if (d2 < rc2) flags_[k] |= kBlocked;
  });
}

// Dijkstra over traversable cells, 8-connected (diagonal steps cost √2·res and may not
// cut a blocked corner). The start cell and the rest of the robot's footprint are
// traversable, even when inflated or unknown, so a robot close to a wall, or one whose
// laser has not yet seen the cells under its own body, still gets a plan. Frontier cells are
// considered as they settle, i.e. nearest first, which makes the spacing rule keep the
// nearest cell of each stretch of frontier.
void FrontierBidder::flood_path_cost(const GridGeometry& g, const Cell* cells, std::uint32_t start) {
  const std::size_t n = g.cells();
  std::fill_n(cost_.begin(), n, std::numeric_limits<double>::infinity());
  std::fill_n(heap_pos_.begin(), n, kNotInHeap);
  heap_size_ = 0;
  cost_[start] = 0;
  heap_push_or_decrease(start);
  const double diagonal = g.resolution * std::numbers::sqrt2;
  const auto w = static_cast<std::uint32_t>(g.width);
  while (heap_size_ > 0) {
    const std::uint32_t c = heap_pop();
    flags_[c] |= kSettled;
    ++stats_.reached_cells;
    consider(g, cells, c);
    const int i = static_cast<int>(c % w), j = static_cast<int>(c / w);
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if ((di == 0 && dj == 0) || !g.contains(i + di, j + dj)) continue;
        const std::size_t nb = g.index(i + di, j + dj);
        if (flags_[nb] & (kBlocked | kSettled)) continue;
        const bool diag = di != 0 && dj != 0;
        if (diag && ((flags_[g.index(i + di, j)] & kBlocked) || (flags_[g.index(i, j + dj)] & kBlocked))) continue;
        const double nc = cost_[c] + (diag ? diagonal : g.resolution);
        if (nc < cost_[nb]) {
          cost_[nb] = nc;
          heap_push_or_decrease(static_cast<std::uint32_t>(nb));
        }
      }
  }
}

// The cell's class for the bid: the robot's footprint is clear.
Cell FrontierBidder::class_of(const Cell* cells, std::size_t k) const {
  return (flags_[k] & kFootprint) ? Cell::kClear : cells[k];
}

// A frontier cell: clear, with an unknown 4-neighbour (4, not 8: an unknown cell seen only
// diagonally, past the corner of a wall, is not an opening). Never a cell of the robot's
// footprint: the robot stands there already (it would "arrive" at once, bid it again and
// never move; what lies behind it is reached from the frontier cells beside it).
bool FrontierBidder::is_frontier(const GridGeometry& g, const Cell* cells, int i, int j) const {
  const std::size_t k = g.index(i, j);
  if ((flags_[k] & kFootprint) || cells[k] != Cell::kClear || !in_area(i, j)) return false;
  for (int d = 0; d < 4; ++d)
    if (g.contains(i + kDi4[d], j + kDj4[d]) && unknown(cells, g, i + kDi4[d], j + kDj4[d])) return true;
  return false;
}

void FrontierBidder::consider(const GridGeometry& g, const Cell* cells, std::uint32_t cell) {
  const auto w = static_cast<std::uint32_t>(g.width);
  if ((flags_[cell] & kNearKept) || !is_frontier(g, cells, static_cast<int>(cell % w), static_cast<int>(cell / w)))
    return;
  mark_spacing(g, cell);
  ++stats_.candidates;
  Candidate c;
  c.cell = cell;
  c.cost = cost_[cell];
  measure_gain(g, cells, &c);
  if (c.gain < config_.min_gain_cells) {
    ++stats_.below_min_gain;
    return;
  }
  c.utility = static_cast<double>(c.gain) - config_.gain_per_metre * c.cost;
  offer(c);
}

// Breadth-first over unknown cells, 4-connected (an 8-connected fill would leak through a
// diagonal line of wall cells), seeded from the frontier cell's unknown 4-neighbours,
// within sensor_range_m of the frontier cell's centre; clear and obstacle cells stop it.
void FrontierBidder::measure_gain(const GridGeometry& g, const Cell* cells, Candidate* c) {
  if (++gain_epoch_ == 0) {  // wrapped: forget every old stamp
    std::fill(gain_stamp_.begin(), gain_stamp_.end(), 0);
    gain_epoch_ = 1;
  }
  const auto w = static_cast<std::uint32_t>(g.width);
  const int fi = static_cast<int>(c->cell % w), fj = static_cast<int>(c->cell / w);
  const double range = config_.sensor_range_m / g.resolution;
  const double range2 = range * range + kEps;
  std::size_t head = 0, tail = 0;
  auto visit = [&](int i, int j) {
    if (!g.contains(i, j)) return;
    const std::size_t k = g.index(i, j);
    if (class_of(cells, k) != Cell::kUnknown || gain_stamp_[k] == gain_epoch_) return;
    const double di = i - fi, dj = j - fj;
    if (di * di + dj * dj > range2) return;
    if (!in_area(i, j) || in_wall_gap(g, cells, i, j)) {  // stamped: not tested again by this flood
      gain_stamp_[k] = gain_epoch_;
      ++(in_area(i, j) ? stats_.wall_gap_cells : stats_.outside_area_cells);
      return;
    }
    gain_stamp_[k] = gain_epoch_;
    gain_queue_[tail++] = static_cast<std::uint32_t>(k);
  };
  for (int d = 0; d < 4; ++d) visit(fi + kDi4[d], fj + kDj4[d]);
  c->igr_i0 = c->igr_j0 = std::numeric_limits<int>::max();
  c->igr_i1 = c->igr_j1 = std::numeric_limits<int>::min();
  while (head < tail) {
    const std::uint32_t k = gain_queue_[head++];
    const int i = static_cast<int>(k % w), j = static_cast<int>(k / w);
    c->igr_i0 = std::min(c->igr_i0, i);
    c->igr_j0 = std::min(c->igr_j0, j);
    c->igr_i1 = std::max(c->igr_i1, i);
    c->igr_j1 = std::max(c->igr_j1, j);
    for (int d = 0; d < 4; ++d) visit(i + kDi4[d], j + kDj4[d]);
  }
  c->gain = static_cast<std::uint32_t>(tail);
  stats_.gain_cells_visited += tail;
}

// True when (i, j) lies in a run of at most n = wall_gap_n_ (floor(wall_gap_m / resolution)) unknown
// cells closed by an obstacle cell at both ends, along a row, a column or a diagonal. At a
// grazing angle the beams step along a wall further apart than a cell, so a wall seen from
// afar keeps holes one or two cells wide; behind them lies the unknown outside the
// building or inside a block, which no robot can see. Work: at most 4 · 2n cell reads,
// n <= kMaxWallGapCells.
bool FrontierBidder::in_wall_gap(const GridGeometry& g, const Cell* cells, int i, int j) const {
  const int n = wall_gap_n_;
  if (n < 1) return false;
  // Steps from (i, j) along (di, dj) to the first obstacle over unknown cells only, at most
  // n; n + 1 when there is none (clear cell, map edge or too far).
  auto to_obstacle = [&](int di, int dj) {
    for (int s = 1; s <= n; ++s) {
      const int a = i + s * di, b = j + s * dj;
      if (!g.contains(a, b)) return n + 1;
      const Cell c = class_of(cells, g.index(a, b));
      if (c == Cell::kObstacle) return s;
      if (c != Cell::kUnknown || !in_area(a, b)) return n + 1;
    }
    return n + 1;
  };
  static constexpr int kDirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (const auto& d : kDirs) {
    const int ahead = to_obstacle(d[0], d[1]);
    if (ahead > n) continue;
    const int behind = to_obstacle(-d[0], -d[1]);
    if (ahead + behind - 1 <= n) return true;  // the run's length in unknown cells
  }
  return false;
}

void FrontierBidder::mark_spacing(const GridGeometry& g, std::uint32_t cell) {
  const double s = config_.frontier_spacing_m / g.resolution;
  const double s2 = s * s - kEps;
  const int reach = static_cast<int>(std::ceil(s));
  const auto w = static_cast<std::uint32_t>(g.width);
  const int i = static_cast<int>(cell % w), j = static_cast<int>(cell / w);
  for (int dj = std::max(-reach, -j); dj <= std::min(reach, g.height - 1 - j); ++dj)
    for (int di = std::max(-reach, -i); di <= std::min(reach, g.width - 1 - i); ++di)
      if (di * di + dj * dj < s2) flags_[g.index(i + di, j + dj)] |= kNearKept;
}

// Keeps the max_items best candidates, best first: higher utility, then lower cost, then
// lower cell index (deterministic).
void FrontierBidder::offer(const Candidate& c) {
  auto better = [](const Candidate& a, const Candidate& b) {
    if (a.utility != b.utility) return a.utility > b.utility;
    if (a.cost != b.cost) return a.cost < b.cost;
    return a.cell < b.cell;
  };
  std::size_t k = n_best_;
  if (n_best_ < config_.max_items) {
    ++n_best_;
  } else if (better(c, best_[n_best_ - 1])) {
    k = n_best_ - 1;
  } else {
    return;
  }
  while (k > 0 && better(c, best_[k - 1])) {
    best_[k] = best_[k - 1];
    --k;
  }
  best_[k] = c;
}

void FrontierBidder::heap_push_or_decrease(std::uint32_t cell) {  // cost_[cell] already lowered
  if (heap_pos_[cell] == kNotInHeap) {
    heap_[heap_size_] = cell;
    heap_pos_[cell] = static_cast<std::uint32_t>(heap_size_);
    ++heap_size_;
  }
  sift_up(heap_pos_[cell]);
}

std::uint32_t FrontierBidder::heap_pop() {
  const std::uint32_t top = heap_[0];
  heap_pos_[top] = kNotInHeap;
  if (--heap_size_ > 0) {
    heap_[0] = heap_[heap_size_];
    heap_pos_[heap_[0]] = 0;
    sift_down(0);
  }
  return top;
}

void FrontierBidder::sift_up(std::size_t k) {
  const std::uint32_t cell = heap_[k];
  const double c = cost_[cell];
  while (k > 0) {
    const std::size_t parent = (k - 1) / 2;
    if (cost_[heap_[parent]] <= c) break;
    heap_[k] = heap_[parent];
    heap_pos_[heap_[k]] = static_cast<std::uint32_t>(k);
    k = parent;
  }
  heap_[k] = cell;
  heap_pos_[cell] = static_cast<std::uint32_t>(k);
}

void FrontierBidder::sift_down(std::size_t k) {
  const std::uint32_t cell = heap_[k];
  const double c = cost_[cell];
  for (;;) {
    std::size_t child = 2 * k + 1;
    if (child >= heap_size_) break;
    if (child + 1 < heap_size_ && cost_[heap_[child + 1]] < cost_[heap_[child]]) ++child;
    if (cost_[heap_[child]] >= c) break;
    heap_[k] = heap_[child];
    heap_pos_[heap_[k]] = static_cast<std::uint32_t>(k);
    k = child;
  }
  heap_[k] = cell;
  heap_pos_[cell] = static_cast<std::uint32_t>(k);
}

}  // namespace cairn::explore
