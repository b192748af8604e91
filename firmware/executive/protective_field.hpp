// The laser protective field: a speed limit from the last scan, so that the robot can
// always stop before its body reaches anything the laser sees on the path it is driving.
//
// The path is the arc the requested (v, w) drives; the body is a disc of `radius_m`,
// widened by `side_margin_m`. For each return in that swept band the free travel s is
// the arc length the body can cover before touching it. The robot can stop within s from
// speed v when v·reaction_s + v²/(2·max_acc) + front_margin_m <= s, so the field allows
// the largest such v over all returns. Returns include other robots' bodies (they move;
// the reaction time covers a scan's age). Turning in place sweeps nothing outside a disc
// and is always allowed; reverse is capped at reverse_max_v (a forward-facing laser
// cannot guard it). Pure and allocation-free after construction: on_scan copies at most
// lms::kMaxBeams points, limit() visits each once (the work per RT cycle is bounded by
// the scan's beam count).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include "common/se2.hpp"
#include "drivers/sick/lms_codec.hpp"

namespace cairn::firmware {

struct ProtectiveFieldConfig {
  bool enabled = true;
  double radius_m = 0.3;         // the body's radius (a disc about the wheel axle's centre)
  double side_margin_m = 0.02;   // added to the radius for the swept band
  double front_margin_m = 0.05;  // left between the body and the nearest return after stopping
  double reaction_s = 0.1;       // command to wheels braking (RT cycle, CAN, drive), and a scan's age
  double reverse_max_v = 0.1;    // m/s backwards, unguarded
  double restart_m = 0.02;       // after a protective stop, forward again only when this much more is free
  /// Empty when sound; else why not (the distance at max_v must stay inside the laser's range).
  std::string check(double max_v, double max_acc, double laser_range_m) const;
};

struct FieldLimit {
  double forward_max_v = 0;  // m/s; 0: blocked
  /// The speed that still stops before the return braking at max_acc now, with no reaction
  /// time: above it the robot cannot stop in time by ramping down (something stepped in).
  double brake_max_v = 0;
  double reverse_max_v = 0;
  double free_m = 0;         // free travel along the requested arc (capped at the field's reach)
  Vec2 nearest{0, 0};        // the return that limits, robot frame (when one does)
  bool limited = false;      // a return lies inside the field's reach
};

class ProtectiveField {
 public:
  ProtectiveField(const ProtectiveFieldConfig& config, double max_v, double max_acc);

  /// The scan's returns (mm; 0 = none), beam angles from `angle_min` by `increment` in the
  /// laser's frame, the laser at `mount` on the robot. Replaces the previous scan.
  void on_scan(const std::uint16_t* range_mm, std::size_t count, double angle_min, double increment,
               const Pose2& mount);
  /// The limit for driving (v, w) now, the robot having moved by `since_scan` since the
  /// scan's pose (odometry). No scan yet: blocked forward.
  FieldLimit limit(double v, double w, const Pose2& since_scan) const;
  /// Stopping distance from speed v (m), margins included.
  double stopping_distance(double v) const;
  /// The largest speed that stops within `free_m`.
  double speed_for(double free_m) const;
  /// The same without the reaction time: braking at max_acc from now.
  double braking_speed_for(double free_m) const;
  const ProtectiveFieldConfig& config() const { return cfg_; }

 private:
  ProtectiveFieldConfig cfg_;
  double max_acc_;
  double reach_;  // stopping distance at max_v: returns farther along the path never limit
  std::array<Vec2, lms::kMaxBeams> points_{};
  std::size_t count_ = 0;
  bool have_scan_ = false;
};

}  // namespace cairn::firmware
