#include "firmware/explore/block_marks.hpp"

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

void BlockMarks::stamp(ClassGrid* grid, Nanos now) const {
  const GridGeometry& g = grid->geometry;
  const double r = cfg_.radius_m;
  const int reach = static_cast<int>(std::ceil(r / g.resolution));
  for (const Mark& m : marks_) {
    if (m.until < now) continue;
    const int ci = static_cast<int>(std::floor((m.at.x() - g.origin_x) / g.resolution));
    const int cj = static_cast<int>(std::floor((m.at.y() - g.origin_y) / g.resolution));
    for (int j = cj - reach; j <= cj + reach; ++j) {
      for (int i = ci - reach; i <= ci + reach; ++i) {
        if (!g.contains(i, j)) continue;
        if ((i == ci && j == cj) || (g.center(i, j) - m.at).norm() <= r) grid->at(i, j) = Cell::kObstacle;
      }
    }
    if (cfg_.keep_right_m <= 0 || m.barrier_until < now) continue;
    // The barrier, a line of cells (sampled every half cell: 8-connected, and the planner
    // neither crosses an inflated cell nor cuts a blocked corner).
    const int steps = static_cast<int>(std::ceil(2 * cfg_.keep_right_m / g.resolution));
    for (int k = 0; k <= steps; ++k) {
      const Vec2 p = m.at + (cfg_.keep_right_m * k / steps) * m.left;
      const int i = static_cast<int>(std::floor((p.x() - g.origin_x) / g.resolution));
      const int j = static_cast<int>(std::floor((p.y() - g.origin_y) / g.resolution));
      if (g.contains(i, j)) grid->at(i, j) = Cell::kObstacle;
    }
  }
}

}  // namespace cairn::explore
