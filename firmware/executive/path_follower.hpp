// A pure-pursuit path follower on the robot's corrected local pose: waypoints in the
// local frame, a lookahead that grows with the robot's speed, a cruise speed; turns in
// place when the target is far off the heading. Non-RT (it runs beside DDS); its output
// goes to the RT loop through a LatestBox. Pure.
#pragma once

#include <cstddef>
#include <vector>

#include "common/se2.hpp"

namespace cairn::firmware {

struct FollowerConfig {
  double speed = 0.5, turn_in_place_rad = 0.8, goal_tolerance = 0.15, max_w = 1.2;
  // Lookahead L = clamp(lookahead_time_s · |v|, lookahead_min, lookahead_max) with v the
  // speed the robot is commanded now (after the ramp): short while starting and slowing
  // near a waypoint, where it must hold the line; long at speed, where a short one
  // oscillates. At the default cruise (0.5 m/s) L is 0.6 m.
  double lookahead_time_s = 1.2, lookahead_min = 0.3, lookahead_max = 1.5;
  bool loop = false;
  /// The lookahead at speed `v`.
  double lookahead(double v) const;
  /// Why the lookahead settings are unusable ("" when fine).
  const char* check() const;
};

class PathFollower {
 public:
  PathFollower(std::vector<Vec2> waypoints, const FollowerConfig& c) : wp_(std::move(waypoints)), c_(c) {}
  /// Velocity for the current pose, with `speed_now` the robot's present forward speed;
  /// false when the path is done (v = w = 0).
  bool command(const Pose2& pose, double speed_now, double* v, double* w);
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
