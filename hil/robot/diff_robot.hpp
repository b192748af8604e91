// A simulated differential-drive robot in the HIL world: its two wheels are the emulated
// drives' motors (velocity in increments/s, through the drive geometry), its pose is
// integrated from them, it is a circle with a reflective marker in the world, and it
// stops at obstacles (a bumper) instead of passing through them.
#pragma once

#include "drivers/canopen/diff_drive.hpp"
#include "hil/world/world.hpp"

namespace cairn::hil {

class DiffRobot {
 public:
  DiffRobot(int id, const canopen::DiffDriveGeometry& g, const Pose2& start, double radius, World* world)
      : id_(id), g_(g), pose_(start), radius_(radius), world_(world) {
    world_->set_robot(id_, pose_, radius_);
  }
  /// Advances by dt with the motors' velocities (drive units; the right motor mirrored as configured).
  void step(double left_motor, double right_motor, double dt);
  /// True wheel radius / nominal, per wheel: what makes odometry drift (1 = perfect).
  void set_wheel_scale(double left, double right) {
    scale_left_ = left;
    scale_right_ = right;
  }
  const Pose2& pose() const { return pose_; }
  double odometer() const { return odometer_; }
  std::uint64_t bumps() const { return bumps_; }

 private:
  int id_;
  canopen::DiffDriveGeometry g_;
  Pose2 pose_;
  double radius_;
  World* world_;
  double odometer_ = 0;
  std::uint64_t bumps_ = 0;
  double scale_left_ = 1.0, scale_right_ = 1.0;
};

}  // namespace cairn::hil
