#include "firmware/executive/robot_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/log.hpp"

namespace cairn::firmware {

RobotCore::RobotCore(const ExecutiveConfig& cfg)
    : cfg_(cfg),
      mapper_(cfg.localmap),
      odometry_(cfg.geometry, cfg.odometry),
      safety_(cfg.safety),
      field_(cfg.field, cfg.safety.max_v, cfg.safety.max_acc),
      steps_(std::max<std::size_t>(cfg.odometry_history, 1)),
      points_(std::make_unique<Vec2[]>(lms::kMaxBeams)),
      laser_msg_(std::make_unique<msg::LaserScan>()),
      feature_msg_(std::make_unique<msg::FeatureObservations>()) {
  mapper_.reset(Pose2{});
}

void RobotCore::on_wheels(const WheelReading& ws) {
  drives_enabled_ = ws.enabled;
  last_feedback_ = ws.feedback_stamp;
  last_can_pass_ = ws.pass;
  if (ws.stamp == last_wheel_stamp_) return;
  const Nanos t0 = last_wheel_stamp_ < 0 ? ws.stamp : last_wheel_stamp_;
  last_wheel_stamp_ = ws.stamp;
  TimedStep oldest;
  if (steps_.full() && steps_.pop(&oldest)) accumulate(&folded_, oldest.step);  // joins the folded prefix
  steps_.push({t0, ws.stamp, odometry_.update(ws.left, ws.right)});
}

canopen::WheelCommand RobotCore::control(const ControlInputs& c, double dt) {
  SafetyInputs in;
  in.now = c.now;
  in.estop = c.estop;
  in.drives_enabled = drives_enabled_;
  in.last_link = c.last_link;
  in.last_scan = last_scan_;
  in.last_command = c.command_stamp;
  in.last_power = c.last_power;
  in.last_feedback = last_feedback_;
  in.last_can_pass = last_can_pass_;
  in.reset = c.reset;
  in.remote_stop = c.remote_stop;
  in.v = c.v;
  in.w = c.w;
  // The last scan's returns, moved by the odometry since (about 27 ms at most), guard both
  // the arc requested (as the supervisor will clamp it; NaN: blocked) and the arc being
  // driven (the ramps take a while to bend it onto the new one).
  const SafetyLimits& lim = cfg_.safety;
  const double rv = std::isfinite(c.v) ? std::clamp(c.v, -lim.max_v, lim.max_v) : c.v;
  const double rw = std::isfinite(c.w) ? std::clamp(c.w, -lim.max_w, lim.max_w) : c.w;
  const Pose2 since_scan = odometry_pending().delta;
  const FieldLimit requested = field_.limit(rv, rw, since_scan);
  // The arc being driven matters while the robot would cover more than 5 cm on it before
  // the turn-rate ramp bends it onto the requested one (at a crawl it never does).
  const double bend_s = std::isfinite(rw) ? std::abs(w_ - rw) / lim.max_alpha : 0.0;
  const FieldLimit driving = v_ * bend_s > 0.05 ? field_.limit(v_, w_, since_scan) : requested;
  field_limit_ = driving.forward_max_v < requested.forward_max_v ? driving : requested;
  in.field_forward_max_v = std::min(requested.forward_max_v, driving.forward_max_v);
  // Stopped by the field, it starts again only once restart_m more is free: range noise at
  // the stopping point must not make it creep and stop, over and over.
  if (stop_ == StopReason::kProtectiveField && field_limit_.free_m < cfg_.field.front_margin_m + cfg_.field.restart_m) {
    in.field_forward_max_v = 0;
  }
  in.field_brake_max_v = std::min(requested.brake_max_v, driving.brake_max_v);
  in.field_reverse_max_v = requested.reverse_max_v;
  double v = 0, w = 0;
  const StopReason reason = safety_.evaluate(in, dt, &v, &w);
  if (reason != stop_ && reason != StopReason::kNone) {
    CAIRN_LOG_WARN("safety", "stop: {}", stop_reason_text(reason));
  } else if (reason != stop_) {
    CAIRN_LOG_INFO("safety", "clear: {} is over", stop_reason_text(stop_));
  }
  stop_ = reason;
  v_ = v;
  w_ = w;
  return canopen::wheel_command(cfg_.geometry, v, w);
}

Pose2 RobotCore::local_pose() const { return compose(mapper_.pose(), odometry_pending().delta); }

CoreCounters RobotCore::counters() const { return {mapper_.counters().scans, mapper_.counters().matched}; }

OdometryStep RobotCore::odometry_until(Nanos t) {
  OdometryStep out = folded_;
  folded_ = OdometryStep{};
  TimedStep done;
  while (!steps_.empty() && steps_.oldest().t <= t && steps_.pop(&done)) accumulate(&out, done.step);
  // A wheel sample that spans t (several merged when the RT loop woke late): take the part
  // of its arc before t, leave the rest queued.
  if (!steps_.empty()) {
    TimedStep& s = steps_.oldest();
    if (s.t0 < t && s.t > s.t0) {
      const double f = static_cast<double>(t - s.t0) / static_cast<double>(s.t - s.t0);
      OdometryStep head, tail;
      split_step(s.step, f, &head, &tail);
      accumulate(&out, head);
      s.step = tail;
      s.t0 = t;
    }
  }
  return out;
}

OdometryStep RobotCore::odometry_pending() const {
  OdometryStep out = folded_;
  for (std::size_t i = 0; i < steps_.size(); ++i) accumulate(&out, steps_[i].step);
  return out;
}

void RobotCore::on_scan(const lms::LmsScan& scan, Nanos now, RobotOutputs& out) {
  last_scan_ = now;
  ++scans_seen_;
  // Features first: the beams on other robots' bodies are left out of the match (they
  // move; matched, they drag this robot's local frame along with them).
  extract_features(scan, cfg_.laser_mount, cfg_.features, &features_);
  // Every return, other robots' bodies included, guards the path.
  field_.on_scan(scan.range_mm.data(), scan.count, scan.angle_min, scan.angle_increment, cfg_.laser_mount);
  std::size_t next_robot = 0;  // features come in beam order
  auto on_robot = [&](std::size_t beam) {
    for (; next_robot < features_.count; ++next_robot) {
      const ScanFeature& f = features_.items[next_robot];
      if (f.robot && beam <= f.last_beam) return beam >= f.first_beam;
    }
    return false;
  };
  // Points in the robot frame, the laser's mount applied.
  std::size_t n = 0;
  const double min_r = cfg_.localmap.min_range_m, max_r = cfg_.localmap.max_range_m;
  for (std::size_t i = 0; i < scan.count; ++i) {
    const double r = scan.range_mm[i] * 1e-3;
    if (scan.range_mm[i] == 0 || r < min_r || r > max_r || on_robot(i)) continue;
    const double a = scan.angle(i);
    points_[n++] = transform_point(cfg_.laser_mount, Vec2(r * std::cos(a), r * std::sin(a)));
  }
  // Odometry up to the middle of the sweep, where the scan (matched as a rigid body) was
  // taken on average; motion after it stays for the next scan. Taking all of it made
  // the pose run ahead of the scan along a corridor, where the match cannot correct it.
  const Nanos mid_sweep = scan.stamp + static_cast<Nanos>(0.5 * scan.beam_period_s * scan.count * 1e9);
  const OdometryStep odom = odometry_until(mid_sweep);
  Mat3 odom_cov = odom.covariance;
  odom_cov.diagonal().array() += 1e-8;
  const localmap::LocalMapUpdate u = mapper_.add_scan(std::span<const Vec2>(points_.get(), n), odom.delta, odom_cov);

  // OdometryIncrement: the corrected motion since the previous scan and its covariance.
  msg::OdometryIncrement inc;
  inc.robot_id = cfg_.robot_id;
  inc.boot_epoch = cfg_.boot_epoch;
  inc.seq = ++odom_seq_;
  inc.t0 = last_odom_t_ ? last_odom_t_ : scan.stamp;
  inc.t1 = scan.stamp;
  last_odom_t_ = scan.stamp;
  inc.delta = u.increment;
  inc.delta_cov = msg::to_cov(u.covariance);
  inc.local_pose = u.pose;
  out.odometry(inc);

  // Every Nth scan to the base station, with its corrected pose.
  if (scans_seen_ % static_cast<std::uint32_t>(cfg_.scan_publish_every) == 0) {
    msg::LaserScan& m = *laser_msg_;
    m.robot_id = cfg_.robot_id;
    m.seq = ++laser_seq_;
    m.stamp = scan.stamp;
    m.angle_min = static_cast<float>(scan.angle_min);
    m.angle_increment = static_cast<float>(scan.angle_increment);
    m.beam_period_s = static_cast<float>(scan.beam_period_s);
    m.n_beams = scan.count;
    std::memcpy(m.ranges_mm.data(), scan.range_mm.data(), sizeof(std::uint16_t) * scan.count);
    std::memcpy(m.reflectivity.data(), scan.flags.data(), scan.count);
    m.pose = compose(u.pose, cfg_.laser_mount);
    m.pose_cov = msg::to_cov(u.covariance);
    m.sensor_offset = cfg_.laser_mount;
    out.laser(m);
  }

  // Retroreflective features.
  // A scan up to a quarter period (at most 2 ms) early counts as due: stamp jitter must not
  // push a period that is a multiple of the scan interval to the scan after.
  const Nanos early = std::min<Nanos>(cfg_.feature_period / 4, 2 * kNanosPerMilli);
  const bool feature_due = !features_sent_ || scan.stamp - last_feature_stamp_ >= cfg_.feature_period - early;
  if (!feature_due) return;
  if (features_.count > 0) {
    last_feature_stamp_ = scan.stamp;
    features_sent_ = true;
    msg::FeatureObservations& f = *feature_msg_;
    f.robot_id = cfg_.robot_id;
    f.boot_epoch = cfg_.boot_epoch;
    f.seq = ++feature_seq_;
    f.stamp = scan.stamp;
    f.local_pose = u.pose;
    f.odom_seq = inc.seq;
    f.n_features = static_cast<std::uint8_t>(features_.count);
    for (std::size_t i = 0; i < features_.count; ++i) {
      const ScanFeature& s = features_.items[i];
      msg::Feature& o = f.features[i];
      o.kind = s.robot ? msg::FeatureKind::kRobot : msg::FeatureKind::kLandmark;
      o.marker_id = s.marker_id;
      o.range = s.range;
      o.bearing = s.bearing;
      o.cov = {s.covariance(0, 0), s.covariance(0, 1), s.covariance(0, 1), s.covariance(1, 1)};
    }
    out.features(f);
  }
}

}  // namespace cairn::firmware
