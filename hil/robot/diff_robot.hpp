// A simulated differential-drive robot in the HIL world: its two wheels are the emulated
// drives' motors (velocity in increments/s, through the drive geometry), its pose is
// integrated from them, it is a circle with a reflective marker in the world, and it
// stops at obstacles (a bumper) instead of passing through them. With FleetBodies it also
// stops at the other robots' bodies (a shared world on the HIL bench); those contacts are
// counted apart from bumps into the world's own obstacles.
#pragma once

#include "drivers/canopen/diff_drive.hpp"
#include "hil/world/fleet_bodies.hpp"
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
  /// The other robots' bodies to stop at (null: none, as before); this robot's body must be
  /// among them. Set before the first step.
  void share_bodies(FleetBodies* bodies) { bodies_ = bodies; }
  const Pose2& pose() const { return pose_; }
  double odometer() const { return odometer_; }
  /// Steps blocked by the world's obstacles (walls, circles, robots placed in `world`).
  std::uint64_t bumps() const { return bumps_; }
  /// Those of them driving forward (faster than kCreep_mps): into something ahead. A disc
  /// touching a wall also "bumps" when it turns in place or reverses (the wheels' unequal
  /// radii move its centre a few micrometres), which is no reason to back off.
  std::uint64_t front_bumps() const { return front_bumps_; }
  static constexpr double kCreep_mps = 0.02;
  /// Steps blocked by another robot's body in the shared FleetBodies.
  std::uint64_t robot_contacts() const { return robot_contacts_; }

 private:
  void turn_in_place(double theta);
  int id_;
  canopen::DiffDriveGeometry g_;
  Pose2 pose_;
  double radius_;
  World* world_;
  FleetBodies* bodies_ = nullptr;
  double odometer_ = 0;
  std::uint64_t bumps_ = 0, front_bumps_ = 0, robot_contacts_ = 0;
  double scale_left_ = 1.0, scale_right_ = 1.0;
};

}  // namespace cairn::hil
