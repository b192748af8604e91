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
  for (Mark& m : marks_) {
    if (m.until >= now && (m.at - at).norm() < cfg_.radius_m) {
      m.until = now + cfg_.memory;  // held on by the same return: renewed
      return true;
    }
  }
  marks_[next_] = {at, now + cfg_.memory};
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
  }
}

}  // namespace cairn::explore
