#include "tools/sim/sim_robot.hpp"

#include <cmath>

namespace cairn::sim {

namespace {
std::vector<Vec2> there_and_back(const std::vector<Vec2>& route, const Pose2& start) {
  // The follower works in the robot's local frame, whose origin is the start pose.
  std::vector<Vec2> out;
  if (route.empty()) return out;  // no route: the robot stands where it starts
  const Pose2 to_local = inverse(start);
  for (const Vec2& p : route) out.push_back(transform_point(to_local, p));
  for (auto it = route.rbegin() + (route.size() > 1 ? 1 : 0); it != route.rend(); ++it) out.push_back(transform_point(to_local, *it));
  out.push_back(Vec2::Zero());  // back to the start, then loop
  return out;
}
}  // namespace

SimRobot::SimRobot(const SimRobotConfig& cfg, hil::World* world)
    : cfg_(cfg),
      world_(world),
      body_(std::make_unique<hil::DiffRobot>(cfg.id, cfg.robot.geometry, cfg.start, cfg.body_radius_m, world)),
      core_(cfg.robot),
      follower_(cfg.scripted ? there_and_back(cfg.route, cfg.start) : std::vector<Vec2>{},
                [&] {
                  firmware::FollowerConfig f = cfg.follower;
                  f.loop = true;
                  return f;
                }()),
      rng_(cfg.seed),
      slip_(0.0, cfg.slip_sigma) {
  angle_deg_ = cfg.robot.lms.angle_deg;
  res_centideg_ = cfg.robot.lms.resolution_centideg;
  const int rotations = res_centideg_ == 100 ? 1 : (res_centideg_ == 50 ? 2 : 4);  // interlaced sweeps
  sweep_period_ = rotations * kNanosPerSecond / 75;
  sweep_time_ = static_cast<Nanos>(angle_deg_ / 360.0 / 75.0 * 1e9);
  // Lasers are not synchronised: each robot's sweeps start at its own phase (this also
  // spreads the scan-matching work of a step over the worker threads).
  next_sweep_ = sweep_period_ + ((cfg.id - 1) % 3) * sweep_period_ / 3;
  beams_.resize(static_cast<std::size_t>(hil::sweep_beams(angle_deg_, res_centideg_)));
  for (int i = 0; i < 4; ++i) free_scans_.push_back(std::make_unique<lms::LmsScan>());
  body_->set_wheel_scale(cfg.wheel_scale_left, cfg.wheel_scale_right);
}

void SimRobot::set_path(std::vector<Vec2> local_waypoints, Nanos now, Nanos back_off, double back_off_speed) {
  const bool backing_off = now < back_off_until_;
  back_off_until_ = back_off > 0 && !backing_off ? now + back_off : 0;
  back_off_speed_ = back_off_speed;
  firmware::FollowerConfig f = cfg_.follower;
  f.loop = false;
  follower_ = firmware::PathFollower(std::move(local_waypoints), f);
}

void SimRobot::physics(Nanos /*now*/, Nanos dt) {
  const double s = nanos_to_seconds(dt);
  const double left = command_.left, right = command_.right;
  // The encoders count the motors' turns exactly; the ground the wheels cover is off by the
  // radius error and by slip.
  encoder_left_ += left * s;
  encoder_right_ += right * s;
  body_->set_wheel_scale(cfg_.wheel_scale_left * (1.0 + slip_(rng_)), cfg_.wheel_scale_right * (1.0 + slip_(rng_)));
  body_->step(left, right, s);
}

void SimRobot::sweep(Nanos now) {
  // The sweep ends now; the sensor's pose is taken at its end, as the emulator does.
  const Pose2 sensor = compose(body_->pose(), cfg_.robot.laser_mount);
  hil::synthesize_sweep(*world_, sensor, angle_deg_, res_centideg_, cfg_.max_range_m, cfg_.range_noise_m, rng_,
                        beams_.data(), cfg_.id);
  std::unique_ptr<lms::LmsScan> scan;
  if (!free_scans_.empty()) {
    scan = std::move(free_scans_.back());
    free_scans_.pop_back();
  } else {
    scan = std::make_unique<lms::LmsScan>();
  }
  const std::size_t n = beams_.size();
  scan->seq = static_cast<std::uint32_t>(++scans_);
  scan->count = static_cast<std::uint16_t>(n);
  const double res_deg = res_centideg_ / 100.0;
  scan->angle_min = -angle_deg_ / 2.0 * std::numbers::pi / 180.0;
  scan->angle_increment = res_deg * std::numbers::pi / 180.0;
  scan->beam_period_s = res_deg / 360.0 / 75.0;
  for (std::size_t i = 0; i < n; ++i) {
    const hil::BeamSample& b = beams_[i];
    const long mm = b.hit ? std::lround(std::max(0.0, b.range_m) * 1000.0) : 0;
    scan->range_mm[i] = static_cast<std::uint16_t>(std::min<long>(mm, 65534));
    scan->flags[i] = b.hit && b.reflective ? 1 : 0;
  }
  scan->stamp = now - sweep_time_;
  // The telegram (7 header bytes + 2 per value + status + CRC) on the line before the robot has it.
  const double bytes = 10.0 + 2.0 * static_cast<double>(n);
  const Nanos line = static_cast<Nanos>(bytes * 10.0 / cfg_.baud * 1e9);
  scan->first_byte_time = now;
  in_flight_.push_back({now + line, std::move(scan)});
}

void SimRobot::tick(Nanos now, firmware::RobotOutputs& out) {
  if (now >= next_sweep_) {
    sweep(now);
    next_sweep_ += sweep_period_;
  }
  if (now >= next_control_) {
    // A wheel sample (the drives' TPDOs on SYNC), then the control cycle.
    firmware::WheelReading w;
    w.left = static_cast<std::int32_t>(std::lround(encoder_left_));
    w.right = static_cast<std::int32_t>(std::lround(encoder_right_));
    w.enabled = true;
    w.stamp = now;
    w.feedback_stamp = now;
    w.pass = now;
    core_.on_wheels(w);
  }
  while (!in_flight_.empty() && in_flight_.front().deliver <= now) {
    core_.on_scan(*in_flight_.front().scan, now, out);
    free_scans_.push_back(std::move(in_flight_.front().scan));
    in_flight_.pop_front();
  }
  if (now >= next_control_) {
    next_control_ += cfg_.robot.period;
    double v = 0, w = 0;
    if (now < back_off_until_) {
      v = -back_off_speed_;
    } else {
      follower_.command(core_.local_pose(), core_.v(), &v, &w);
    }
    firmware::ControlInputs in;
    in.now = now;
    in.last_link = now;  // the simulated link carries no liveness (safety's link check is the bench's)
    in.last_power = now;
    in.v = v;
    in.w = w;
    in.command_stamp = now;
    command_ = core_.control(in, nanos_to_seconds(cfg_.robot.period));
  }
}

}  // namespace cairn::sim
