#include "firmware/executive/path_follower.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

double FollowerConfig::lookahead(double v) const {
  return std::max(lookahead_min, std::min(lookahead_max, lookahead_time_s * std::abs(v)));  // no clamp UB on bad settings
}

const char* FollowerConfig::check() const {
  if (!(lookahead_min > 0)) return "lookahead_min must be > 0";
  if (!(lookahead_max >= lookahead_min)) return "lookahead_max must be >= lookahead_min";
  if (!(lookahead_time_s >= 0)) return "lookahead_time_s must be >= 0";
  return "";
}

bool PathFollower::command(const Pose2& pose, double speed_now, double* v, double* w) {
  *v = *w = 0;
  // Each waypoint passed at most once per call: a loop whose waypoints all lie within reach
  // (one waypoint at the robot, say) went round for ever.
  // A waypoint counts as passed within half the cruise lookahead: fixed, so that slowing
  // down near it does not make the robot creep up to it.
  const double pass_radius = std::max(c_.goal_tolerance, c_.lookahead(c_.speed) * 0.5);
  std::size_t passed = 0;
  while (next_ < wp_.size() && passed < wp_.size() && (wp_[next_] - pose.translation()).norm() < pass_radius) {
    from_ = wp_[next_];
    has_from_ = true;
    ++next_;
    ++passed;
    if (next_ == wp_.size() && c_.loop) next_ = 0;
  }
  if (next_ >= wp_.size()) return false;
  if (passed == wp_.size()) return true;  // a loop with nowhere to go: hold still (v = w = 0)
  // Pursue a point a lookahead ahead on the segment to the next waypoint (not the
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
    const double along = std::clamp((pose.translation() - from).dot(seg) / len + c_.lookahead(speed_now), 0.0, len);
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
