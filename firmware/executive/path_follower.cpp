#include "firmware/executive/path_follower.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

bool PathFollower::command(const Pose2& pose, double* v, double* w) {
  *v = *w = 0;
  // Each waypoint passed at most once per call: a loop whose waypoints all lie within reach
  // (one waypoint at the robot, say) went round for ever.
  std::size_t passed = 0;
  while (next_ < wp_.size() && passed < wp_.size() &&
         (wp_[next_] - pose.translation()).norm() < std::max(c_.goal_tolerance, c_.lookahead * 0.5)) {
    from_ = wp_[next_];
    has_from_ = true;
    ++next_;
    ++passed;
    if (next_ == wp_.size() && c_.loop) next_ = 0;
  }
  if (next_ >= wp_.size()) return false;
  if (passed == wp_.size()) return true;  // a loop with nowhere to go: hold still (v = w = 0)
  // Pursue a point `lookahead` ahead on the segment to the next waypoint (not the
  // waypoint itself), so the robot converges onto the line instead of drifting beside it.
  const Vec2 from = has_from_ ? from_ : pose.translation();
  if (!has_from_) {
    from_ = from;
    has_from_ = true;
  }
  const Vec2 seg = wp_[next_] - from;
  const double len = seg.norm();
  Vec2 target = wp_[next_];
  if (len > 1e-6) {
    const double along = std::clamp((pose.translation() - from).dot(seg) / len + c_.lookahead, 0.0, len);
    target = from + seg * (along / len);
  }
  const Vec2 local = inverse_transform_point(pose, target);
  const double heading = std::atan2(local.y(), local.x());
  if (std::abs(heading) > c_.turn_in_place_rad) {
    *w = std::copysign(std::min(c_.max_w, 1.5 * std::abs(heading)), heading);
    return true;
  }
  // Pure pursuit: curvature 2 y / L² towards the target.
  const double l2 = std::max(local.squaredNorm(), 1e-6);
  const double dist = (wp_[next_] - pose.translation()).norm();  // slow down only near the waypoint
  *v = std::min(c_.speed, std::max(0.1, dist));
  *w = std::clamp(*v * 2.0 * local.y() / l2, -c_.max_w, c_.max_w);
  return true;
}

}  // namespace cairn::firmware
