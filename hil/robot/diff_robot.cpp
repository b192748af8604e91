#include "hil/robot/diff_robot.hpp"

#include <cmath>

namespace cairn::hil {

void DiffRobot::step(double left_motor, double right_motor, double dt) {
  const double m_per_count = g_.wheel_radius_m / g_.counts_per_wheel_rad();
  const double vl = left_motor * m_per_count * scale_left_;
  const double vr = (g_.right_inverted ? -right_motor : right_motor) * m_per_count * scale_right_;
  const double v = 0.5 * (vl + vr), w = (vr - vl) / g_.track_m;
  const Pose2 next = compose(pose_, arc_motion(v, w, dt));
  if (world_->collides(next.translation(), radius_, id_)) {
    ++bumps_;  // blocked: the wheels slip, the robot turns in place at most
    if (v > kCreep_mps) ++front_bumps_;
    turn_in_place(next.theta);
    return;
  }
  // Checked against the others' current poses and committed at once (FleetBodies' lock).
  if (bodies_ && bodies_->try_move(id_, next) != 0) {
    ++robot_contacts_;
    turn_in_place(next.theta);
    return;
  }
  odometer_ += std::abs(v * dt);
  pose_ = next;
  world_->set_robot(id_, pose_, radius_);
}

void DiffRobot::turn_in_place(double theta) {
  pose_.theta = theta;
  if (bodies_) bodies_->try_move(id_, pose_);  // same place: always allowed; the others see the new heading
}

}  // namespace cairn::hil
