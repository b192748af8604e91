// One robot in cairn-sim: its body in the shared world (moved by its wheel commands, with
// wheel-radius error and slip noise), its laser (the LMS2xx emulator's measurement model,
// hil/lms2xx/scan_synth), its encoders, and the production robot pipeline (RobotCore)
// following its route with the production path follower. Everything advances on the
// simulation's clock only; the same seed gives the same run, bit for bit.
#pragma once

#include <deque>
#include <memory>
#include <random>
#include <vector>

#include "firmware/executive/path_follower.hpp"
#include "firmware/executive/robot_core.hpp"
#include "hil/lms2xx/scan_synth.hpp"
#include "hil/robot/diff_robot.hpp"

namespace cairn::sim {

struct SimRobotConfig {
  int id = 1;
  Pose2 start;
  std::vector<Vec2> route;  // world frame; driven there and back, repeatedly
  bool scripted = true;     // false: no tour; the robot stands until set_path() (exploration)
  firmware::ExecutiveConfig robot;  // the robot's own configuration (as cairn-robot loads it)
  firmware::FollowerConfig follower;
  double body_radius_m = 0.3;
  double wheel_scale_left = 1.01, wheel_scale_right = 0.995;  // true radius / nominal: odometry drifts
  double slip_sigma = 0.01;        // relative noise on each wheel's true travel per physics step
  double range_noise_m = 0.005;    // as the LMS2xx emulator
  double max_range_m = 30.0;
  std::uint32_t baud = 500000;     // the scan's line time delays its delivery
  std::uint64_t seed = 1;
};

class SimRobot {
 public:
  SimRobot(const SimRobotConfig& cfg, hil::World* world);

  /// Physics over [now, now + dt): the body moves under the current wheel command.
  void physics(Nanos now, Nanos dt);
  /// The robot's work due at `now`: wheel samples and the control cycle every RT period,
  /// sweeps of the laser, scans delivered after their line time; outputs to `out`.
  void tick(Nanos now, firmware::RobotOutputs& out);

  /// Exploration: follow these waypoints (the robot's local frame) from now on, replacing
  /// the current path; an empty path stops the robot. Called between steps only.
  /// Before following it, back straight off at `back_off_speed` for `back_off` from `now`
  /// (0: at once). A new path ends a running back-off, and so does one asked for while it
  /// runs: the robot bumped while backing off, into what is behind it, and restarting the
  /// back-off pushed it on into that for as long as it bumped (20 s in one of world D's runs).
  void set_path(std::vector<Vec2> local_waypoints, Nanos now = 0, Nanos back_off = 0, double back_off_speed = 0);
  /// The current path is finished (or there is none).
  bool path_done() const { return follower_.done(); }

  const Pose2& truth() const { return body_->pose(); }
  /// The robot's local estimate expressed in the world through its (known) start pose.
  Pose2 local_in_world() const { return compose(cfg_.start, core_.local_pose()); }
  double odometer() const { return body_->odometer(); }
  std::uint64_t bumps() const { return body_->bumps(); }
  std::uint64_t front_bumps() const { return body_->front_bumps(); }
  bool backing_off(Nanos now) const { return now < back_off_until_; }
  std::uint64_t scans() const { return scans_; }
  firmware::RobotCore& core() { return core_; }
  int id() const { return cfg_.id; }
  double body_radius() const { return cfg_.body_radius_m; }

 private:
  struct PendingScan {
    Nanos deliver = 0;
    std::unique_ptr<lms::LmsScan> scan;
  };
  void sweep(Nanos now);

  SimRobotConfig cfg_;
  hil::World* world_;
  std::unique_ptr<hil::DiffRobot> body_;
  firmware::RobotCore core_;
  firmware::PathFollower follower_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> slip_;
  std::vector<hil::BeamSample> beams_;
  std::deque<PendingScan> in_flight_;
  std::vector<std::unique_ptr<lms::LmsScan>> free_scans_;
  canopen::WheelCommand command_;
  double encoder_left_ = 0, encoder_right_ = 0;  // motor increments (exact: the drives' encoders)
  Nanos next_control_ = 0, next_sweep_ = 0, sweep_period_ = 0, sweep_time_ = 0;
  int angle_deg_ = 180, res_centideg_ = 50;
  std::uint64_t scans_ = 0;
  Nanos back_off_until_ = 0;
  double back_off_speed_ = 0;
};

}  // namespace cairn::sim
