// A pure-pursuit path follower on the robot's corrected local pose: waypoints in the
// local frame, a lookahead distance, a cruise speed; turns in place when the target is
// far off the heading. Non-RT (it runs beside DDS); its output goes to the RT loop
// through a LatestBox. Pure.
#pragma once

#include <cstddef>
#include <vector>

#include "common/se2.hpp"

namespace cairn::firmware {

struct FollowerConfig {
  double speed = 0.5, lookahead = 0.6, turn_in_place_rad = 0.8, goal_tolerance = 0.15, max_w = 1.2;
  bool loop = false;
};

class PathFollower {
 public:
  PathFollower(std::vector<Vec2> waypoints, const FollowerConfig& c) : wp_(std::move(waypoints)), c_(c) {}
  /// Velocity for the current pose; false when the path is done (v = w = 0).
  bool command(const Pose2& pose, double* v, double* w);
  std::size_t target_index() const { return next_; }
  bool done() const { return next_ >= wp_.size(); }

 private:
  std::vector<Vec2> wp_;
  FollowerConfig c_;
  std::size_t next_ = 0;
  Vec2 from_ = Vec2::Zero();  // start of the current segment
  bool has_from_ = false;
};

}  // namespace cairn::firmware
