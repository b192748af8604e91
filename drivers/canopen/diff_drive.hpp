// A differential-drive robot on two CiA 402 drives: wheel geometry and drive units from
// configuration; wheel speeds in, encoder-based wheel travel and speeds out. Pure.
#pragma once

#include <cstdint>
#include <numbers>

namespace cairn::canopen {

struct DiffDriveGeometry {
  double wheel_radius_m = 0.1;
  double track_m = 0.5;                // distance between the wheels
  double gear_ratio = 20.0;            // motor turns per wheel turn
  double encoder_counts_per_rev = 4096;  // increments per motor turn
  bool right_inverted = true;          // right motor mounted mirrored: positive = backwards

  double counts_per_wheel_rad() const { return encoder_counts_per_rev * gear_ratio / (2.0 * std::numbers::pi); }
};

struct WheelCommand {
  std::int32_t left = 0, right = 0;  // increments/s (0x60FF)
};

/// Body velocity (v m/s, w rad/s) -> target velocities for the two drives.
WheelCommand wheel_command(const DiffDriveGeometry& g, double v, double w);

/// Encoder readings -> wheel travel (m) and body-frame increment since the previous reading.
struct WheelOdometry {
  double left_m = 0, right_m = 0;          // travel since the previous sample
  double left_speed = 0, right_speed = 0;  // m/s from the drives' velocity actual
};
WheelOdometry wheel_odometry(const DiffDriveGeometry& g, std::int32_t left_pos, std::int32_t right_pos,
                             std::int32_t prev_left, std::int32_t prev_right, std::int32_t left_vel, std::int32_t right_vel);

}  // namespace cairn::canopen
