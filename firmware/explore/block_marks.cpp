#include "firmware/explore/block_marks.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::explore {

bool BlockMarks::on_safety(StopReason stop, const Vec2& field_nearest, const Pose2& robot_global, Nanos now) {
  if (stop != StopReason::kProtectiveField) {
    blocked_since_ = -1;
    return false;
  }
  if (blocked_since_ < 0) blocked_since_ = now;
  if (now - blocked_since_ < cfg_.replan_after) return false;
  if (last_ >= 0 && now - last_ < cfg_.replan_after) return false;
  last_ = now;
  const Vec2 at = transform_point(robot_global, field_nearest);
  const Vec2 left(-std::sin(robot_global.theta), std::cos(robot_global.theta));
  if (!at.allFinite() || !left.allFinite()) return false;  // nothing to mark (a NaN would fill the ring)
  for (Mark& m : marks_) {
    if (m.until >= now && (m.at - at).norm() < cfg_.radius_m) {
      m.until = now + cfg_.memory;  // held on by the same return: renewed
      m.left = left;
      m.barrier_until = now + cfg_.keep_right_memory;
      return true;
    }
  }
  marks_[next_] = {at, left, now + cfg_.memory, now + cfg_.keep_right_memory};
  next_ = (next_ + 1) % kMarks;
  ++marked_;
  return true;
}

Nanos BlockMarks::next_barrier_end(Nanos now) const {
  Nanos first = -1;
  for (const Mark& m : marks_) {
    if (m.until < now || m.barrier_until < now || cfg_.keep_right_m <= 0) continue;
    if (first < 0 || m.barrier_until < first) first = m.barrier_until;
  }
  return first;
}

// A count of cells, computed in double and capped (a map's resolution comes over the
// network: a tiny one must not make the loops below run for hours, nor overflow an int).
static int capped_cells(double n, int cap) { return n >= 0 && n < cap ? static_cast<int>(n) : cap; }

// An obstacle cell of `g` within `r` of `at` (cell centres; `at`'s own cell included).
static bool on_map(const ClassGrid& grid, const Vec2& at, double r, int reach) {
  const GridGeometry& g = grid.geometry;
  int ci = 0, cj = 0;
  if (!g.cell_of(at.x(), at.y(), &ci, &cj)) return false;  // off the map: not on it
  for (int j = std::max(cj - reach, 0); j <= std::min(cj + reach, g.height - 1); ++j) {
    for (int i = std::max(ci - reach, 0); i <= std::min(ci + reach, g.width - 1); ++i) {
      if (grid.at(i, j) != Cell::kObstacle) continue;
      if ((i == ci && j == cj) || (g.center(i, j) - at).norm() <= r) return true;
    }
  }
  return false;
}

std::size_t BlockMarks::stamp(ClassGrid* grid, Nanos now, bool barriers) const {
  const GridGeometry& g = grid->geometry;
  const int cap = g.width + g.height;  // no disc or line on the grid needs more cells across
  const double r = cfg_.radius_m;
  const int reach = capped_cells(std::ceil(r / g.resolution), cap);
  // Which marks get a barrier, judged on the map before anything is stamped into it.
  std::array<bool, kMarks> barrier{};
  std::size_t n_barriers = 0;
  for (std::size_t k = 0; k < kMarks; ++k) {
    const Mark& m = marks_[k];
    if (m.until < now || cfg_.keep_right_m <= 0 || m.barrier_until < now) continue;
    barrier[k] = !on_map(*grid, m.at, r + g.resolution, reach + 1);
    if (barrier[k]) ++n_barriers;
  }
  for (std::size_t k = 0; k < kMarks; ++k) {
    const Mark& m = marks_[k];
    if (m.until < now) continue;
    // The mark's cell, clamped just outside the grid (a mark far off it touches nothing).
    const auto cell = [&](double v, double origin, int n) {
      const double c = std::floor((v - origin) / g.resolution);
      return static_cast<int>(std::clamp(c, -1.0 - reach, static_cast<double>(n + reach)));
    };
    const int ci = cell(m.at.x(), g.origin_x, g.width), cj = cell(m.at.y(), g.origin_y, g.height);
    for (int j = std::max(cj - reach, 0); j <= std::min(cj + reach, g.height - 1); ++j) {
      for (int i = std::max(ci - reach, 0); i <= std::min(ci + reach, g.width - 1); ++i) {
        if (!g.contains(i, j)) continue;
        if ((i == ci && j == cj) || (g.center(i, j) - m.at).norm() <= r) grid->at(i, j) = Cell::kObstacle;
      }
    }
    if (!barriers || !barrier[k]) continue;
    // The barrier, a line of cells (sampled every half cell: 8-connected, and the planner
    // neither crosses an inflated cell nor cuts a blocked corner).
    const int steps = std::max(1, capped_cells(std::ceil(2 * cfg_.keep_right_m / g.resolution), 2 * cap));
    for (int s = 0; s <= steps; ++s) {
      const Vec2 p = m.at + (cfg_.keep_right_m * s / steps) * m.left;
      int i = 0, j = 0;
      if (g.cell_of(p.x(), p.y(), &i, &j)) grid->at(i, j) = Cell::kObstacle;
    }
  }
  return n_barriers;
}

}  // namespace cairn::explore
