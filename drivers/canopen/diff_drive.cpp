#include "drivers/canopen/diff_drive.hpp"

#include <cmath>

namespace cairn::canopen {

WheelCommand wheel_command(const DiffDriveGeometry& g, double v, double w) {
  const double vl = v - w * g.track_m / 2.0, vr = v + w * g.track_m / 2.0;  // m/s at each wheel
  const double k = g.counts_per_wheel_rad() / g.wheel_radius_m;             // increments per metre
  WheelCommand c;
  c.left = static_cast<std::int32_t>(std::lround(vl * k));
  c.right = static_cast<std::int32_t>(std::lround((g.right_inverted ? -vr : vr) * k));
  return c;
}

WheelOdometry wheel_odometry(const DiffDriveGeometry& g, std::int32_t left_pos, std::int32_t right_pos,
                             std::int32_t prev_left, std::int32_t prev_right, std::int32_t left_vel, std::int32_t right_vel) {
  const double m_per_count = g.wheel_radius_m / g.counts_per_wheel_rad();
  // Differences in 32-bit arithmetic wrap correctly across the encoder's overflow.
  const auto dl = static_cast<std::int32_t>(static_cast<std::uint32_t>(left_pos) - static_cast<std::uint32_t>(prev_left));
  const auto dr = static_cast<std::int32_t>(static_cast<std::uint32_t>(right_pos) - static_cast<std::uint32_t>(prev_right));
  const double sign_r = g.right_inverted ? -1.0 : 1.0;
  return {dl * m_per_count, sign_r * dr * m_per_count, left_vel * m_per_count, sign_r * right_vel * m_per_count};
}

}  // namespace cairn::canopen
