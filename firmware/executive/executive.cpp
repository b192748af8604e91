#include "firmware/executive/executive.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "common/log.hpp"

namespace cairn::firmware {

namespace {

template <std::size_t N>
void copy_text(std::array<char, N>* dst, const char* src) {
  std::size_t i = 0;  // truncates to fit, always terminated
  for (; i + 1 < N && src[i] != '\0'; ++i) (*dst)[i] = src[i];
  (*dst)[i] = '\0';
}

void store_cov(double out[9], const Mat3& c) {
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) out[r * 3 + k] = c(r, k);
}

void to_msg(cairn_Pose2* m, const Pose2& p) {
  m->x = p.x;
  m->y = p.y;
  m->theta = p.theta;
}

}  // namespace

Executive::Executive(const ExecutiveConfig& cfg, ThreadHooks hooks)
    : cfg_(cfg),
      hooks_(hooks),
      scan_q_(cfg.scan_queue),
      odometry_q_(cfg.odometry_queue),
      laser_q_(cfg.laser_queue),
      feature_q_(cfg.feature_queue),
      mapper_(cfg.localmap),
      odometry_(cfg.geometry, cfg.odometry),
      safety_(cfg.safety),
      steps_(std::make_unique<TimedStep[]>(std::max<std::size_t>(cfg.odometry_history, 1))),
      points_(std::make_unique<Vec2[]>(lms::kMaxBeams)),
      scan_work_(std::make_unique<lms::LmsScan>()),
      laser_msg_(std::make_unique<cairn_LaserScan>()),
      feature_msg_(std::make_unique<cairn_FeatureObservations>()) {
  std::string err;
  can_port_ = can::open_port(cfg.can_uri, &err);
  if (!can_port_) throw std::runtime_error("drives: cannot open CAN port '" + cfg.can_uri + "': " + err);
  master_ = std::make_unique<canopen::DriveMaster>(can_port_.get(), &MonotonicClock::instance(), cfg.master);
  power_ = modbus::PowerBoard::open(cfg.power_uri, cfg.power_map, cfg.power_response_timeout, &err);
  if (!power_) throw std::runtime_error("power board: cannot open '" + cfg.power_uri + "': " + err);
  sink_.self = this;
  (void)logger();  // the RT-safe logger's ring is allocated here, not on first use in a thread
  mapper_.reset(Pose2{});
  std::memset(laser_msg_.get(), 0, sizeof(cairn_LaserScan));
  std::memset(feature_msg_.get(), 0, sizeof(cairn_FeatureObservations));
  snap_ = RtSnapshot{};
  rt_box_.write(snap_);
}

Executive::~Executive() { stop(); }

void Executive::start() {
  if (running_.exchange(true)) return;
  threads_[0] = std::thread([this] { lms_thread(); });
  threads_[1] = std::thread([this] { can_thread(); });
  threads_[2] = std::thread([this] { power_thread(); });
  threads_[3] = std::thread([this] { rt_thread(); });
}

void Executive::stop() {
  if (!running_.exchange(false)) return;
  for (auto& t : threads_)
    if (t.joinable()) t.join();
}

void Executive::set_velocity(double v, double w, Nanos now) { velocity_.write({v, w, now}); }

RtSnapshot Executive::rt_snapshot() {
  RtSnapshot s;
  rt_box_.read(&s);
  s.publish_drops = publish_drops_.load(std::memory_order_relaxed);
  return s;
}

std::size_t Executive::devices(std::array<DeviceSnapshot, 4>* out) {
  for (std::size_t i = 0; i < out->size(); ++i) device_box_[i].read(&(*out)[i]);
  return 4;
}

// ---- laser I/O thread ----------------------------------------------------------------

void Executive::Sink::on_scan(const lms::LmsScan& s) {
  if (!self->scan_q_.push(s)) {
    // Counted by the queue; the RT loop reports it as a queue overflow.
  }
}

void Executive::lms_thread() {
  rt_reports_[0] = "lms: " + apply_rt(cfg_.io_threads);
  auto& clock = MonotonicClock::instance();
  std::string err;
  std::unique_ptr<serial::ByteStream> stream;
  // Open (and keep trying) before steady state: opening may allocate.
  while (running_.load() && !stream) {
    // At the configured rate: a fixed-rate link (tcp: to a device server) stays there; on a
    // serial port the driver probes this rate first, then the others.
    stream = serial::open_stream(cfg_.lms_uri, cfg_.lms.target_baud, &err);
    if (!stream) {
      CAIRN_LOG_WARN("lms", "cannot open {}: {}; retrying", cfg_.lms_uri.c_str(), err.c_str());
      clock.sleep_until(clock.now() + cfg_.lms.reopen_backoff);
    }
  }
  if (!stream) return;
  lms::LmsDriver driver(stream.get(), &clock, cfg_.lms, &sink_);
  if (hooks_.steady) hooks_.steady("lms");
  Nanos next_snapshot = 0;
  DeviceSnapshot d;
  copy_text(&d.name, "lms");
  while (running_.load(std::memory_order_relaxed)) {
    driver.step();
    const Nanos now = clock.now();
    if (now >= next_snapshot) {
      next_snapshot = now + 100 * kNanosPerMilli;
      const auto& c = driver.counters();
      d.state = static_cast<std::uint8_t>(driver.state());
      copy_text(&d.reason, driver.reason());
      d.frames = static_cast<std::uint32_t>(c.scans);
      d.crc_errors = static_cast<std::uint32_t>(c.crc_errors);
      d.resyncs = static_cast<std::uint32_t>(c.resyncs);
      d.timeouts = static_cast<std::uint32_t>(c.timeouts);
      d.recoveries = static_cast<std::uint32_t>(c.reconnects);
      d.errors = static_cast<std::uint32_t>(c.io_errors + c.naks + c.bad_scans);
      device_box_[0].write(d);
    }
  }
  if (hooks_.finished) hooks_.finished("lms");
}

// ---- CAN I/O thread ------------------------------------------------------------------

void Executive::can_thread() {
  rt_reports_[1] = "can: " + apply_rt(cfg_.io_threads);
  auto& clock = MonotonicClock::instance();
  if (hooks_.steady) hooks_.steady("can");
  Nanos next_snapshot = 0;
  std::array<DeviceSnapshot, 2> d;
  copy_text(&d[0].name, "drive_left");
  copy_text(&d[1].name, "drive_right");
  canopen::WheelCommand cmd;
  std::uint64_t updates = 0;
  Nanos wheel_stamp = 0;
  while (running_.load(std::memory_order_relaxed)) {
    if (enable_request_.exchange(false)) master_->enable_all();
    master_->step();
    wheel_cmd_.read(&cmd);
    const std::int32_t velocities[2] = {cmd.left, cmd.right};
    master_->command(velocities);
    const auto& l = master_->feedback(0);
    const auto& r = master_->feedback(1);
    // Written every pass (the enabled flag matters even without new positions); the
    // stamp moves only when new positions arrive.
    if (l.updates + r.updates != updates) {
      updates = l.updates + r.updates;
      wheel_stamp = clock.now();
    }
    wheels_.write({l.position, r.position, updates, master_->all_enabled(), wheel_stamp});
    const Nanos now = clock.now();
    if (now >= next_snapshot) {
      next_snapshot = now + 100 * kNanosPerMilli;
      const auto& bus = can_port_->stats();
      for (std::size_t i = 0; i < 2; ++i) {
        d[i].state = static_cast<std::uint8_t>(master_->phase(i));
        copy_text(&d[i].reason, canopen::phase_name(master_->phase(i)));
        d[i].frames = static_cast<std::uint32_t>(master_->feedback(i).updates);
        d[i].recoveries = static_cast<std::uint32_t>(master_->recoveries());
        d[i].errors = static_cast<std::uint32_t>(bus.error_frames + bus.bus_off);
        d[i].timeouts = static_cast<std::uint32_t>(master_->last_emcy(i));
        device_box_[1 + i].write(d[i]);
      }
    }
  }
  master_->disable_all("shutdown");
  if (hooks_.finished) hooks_.finished("can");
}

// ---- power-board I/O thread ----------------------------------------------------------

void Executive::power_thread() {
  rt_reports_[2] = "power: " + apply_rt(cfg_.io_threads);
  auto& clock = MonotonicClock::instance();
  std::string err;
  err.reserve(256);  // failure messages reuse this buffer
  modbus::PowerState ps;
  DeviceSnapshot d;
  copy_text(&d.name, "power");
  if (hooks_.steady) hooks_.steady("power");
  Nanos next_poll = 0, next_estop = 0;
  while (running_.load(std::memory_order_relaxed)) {
    const Nanos now = clock.now();
    if (now >= next_estop) {
      next_estop = now + cfg_.estop_poll;
      const int e = power_->estop_pressed();
      if (e == 1) {
        if (!estop_.exchange(true)) master_->request_estop();  // the fast path: no RT hop
        last_power_.store(now, std::memory_order_release);
      } else if (e == 0) {
        estop_.store(false);
        last_power_.store(now, std::memory_order_release);
      }
    }
    if (now >= next_poll) {
      next_poll = now + cfg_.power_poll;
      const bool ok = power_->poll(&ps, &err);
      if (ok) power_state_.write(ps);
      const auto& c = power_->counters();
      d.state = ok ? 1 : 0;
      copy_text(&d.reason, ok ? "ok" : err.c_str());
      d.frames = static_cast<std::uint32_t>(c.polls);
      d.timeouts = static_cast<std::uint32_t>(c.timeouts);
      d.recoveries = static_cast<std::uint32_t>(c.reconnects);
      d.errors = static_cast<std::uint32_t>(c.errors + c.invalid);
      device_box_[3].write(d);
    }
    clock.sleep_until(std::min(next_estop, next_poll));
  }
  if (hooks_.finished) hooks_.finished("power");
}

// ---- RT loop -------------------------------------------------------------------------

void Executive::rt_thread() {
  rt_reports_[3] = "rt: " + apply_rt(cfg_.rt_loop);
  auto& clock = MonotonicClock::instance();
  LoopStats stats(cfg_.period);
  if (hooks_.steady) hooks_.steady("rt");
  Nanos deadline = clock.now() + cfg_.period;
  const double dt = nanos_to_seconds(cfg_.period);
  while (running_.load(std::memory_order_relaxed)) {
    clock.sleep_until(deadline);
    const Nanos wake = clock.now();
    rt_cycle(wake, dt);
    const Nanos done = clock.now();
    stats.record(wake, deadline, done);
    snap_.period_mean_us = static_cast<float>(stats.mean_us());
    snap_.period_p99_us = static_cast<float>(stats.p99_us());
    snap_.jitter_max_us = static_cast<float>(stats.max_jitter_us());
    snap_.cycles = stats.cycles();
    snap_.misses = stats.misses();
    rt_box_.write(snap_);
    deadline += cfg_.period;
    if (done > deadline) deadline = done + cfg_.period;  // overran: skip, do not burst
  }
  // Leave the wheels commanded to zero.
  wheel_cmd_.write({});
  if (hooks_.finished) hooks_.finished("rt");
}

void Executive::rt_cycle(Nanos now, double dt) {
  // Wheel odometry since the last cycle.
  WheelState ws;
  if (wheels_.read(&ws) && ws.stamp != last_wheel_stamp_) {
    const Nanos t0 = last_wheel_stamp_ < 0 ? ws.stamp : last_wheel_stamp_;
    last_wheel_stamp_ = ws.stamp;
    const std::size_t cap = std::max<std::size_t>(cfg_.odometry_history, 1);
    if (steps_count_ == cap) {  // full: the oldest step joins the folded prefix
      accumulate(&folded_, steps_[steps_head_].step);
      steps_head_ = (steps_head_ + 1) % cap;
      --steps_count_;
    }
    steps_[(steps_head_ + steps_count_) % cap] = {t0, ws.stamp, odometry_.update(ws.left, ws.right)};
    ++steps_count_;
  }

  // Scans: at most two per cycle (the laser makes < 1 per 10 ms); the rest wait.
  for (int k = 0; k < 2 && scan_q_.pop(scan_work_.get()); ++k) process_scan(*scan_work_);

  // Safety and the wheel command.
  const bool estop = estop_.load(std::memory_order_acquire);
  if (was_estop_ && !estop) enable_request_.store(true);  // released: enable again
  was_estop_ = estop;
  Velocity cmd;
  velocity_.read(&cmd);
  SafetyInputs in;
  in.now = now;
  in.estop = estop;
  in.drives_enabled = ws.enabled;
  in.last_link = last_link_.load(std::memory_order_acquire);
  in.last_scan = last_scan_.load(std::memory_order_acquire);
  in.last_command = cmd.stamp;
  in.last_power = last_power_.load(std::memory_order_acquire);
  in.v = cmd.v;
  in.w = cmd.w;
  double v = 0, w = 0;
  const StopReason reason = safety_.evaluate(in, dt, &v, &w);
  if (reason != snap_.stop && reason != StopReason::kNone) {
    CAIRN_LOG_WARN("safety", "stop: {}", stop_reason_text(reason));
  }
  wheel_cmd_.write(canopen::wheel_command(cfg_.geometry, v, w));

  modbus::PowerState ps;
  power_state_.read(&ps);
  snap_.stop = reason;
  snap_.v = v;
  snap_.w = w;
  snap_.estop = estop;
  snap_.stops = safety_.stops();
  snap_.battery_voltage = ps.voltage;
  snap_.battery_soc = ps.soc;
  snap_.local_pose = compose(mapper_.pose(), odometry_pending().delta);
  snap_.overflows = scan_q_.overflows() + odometry_q_.overflows() + laser_q_.overflows() + feature_q_.overflows();
}

OdometryStep Executive::odometry_until(Nanos t) {
  const std::size_t cap = std::max<std::size_t>(cfg_.odometry_history, 1);
  OdometryStep out = folded_;
  folded_ = OdometryStep{};
  while (steps_count_ > 0 && steps_[steps_head_].t <= t) {
    accumulate(&out, steps_[steps_head_].step);
    steps_head_ = (steps_head_ + 1) % cap;
    --steps_count_;
  }
  // A wheel sample that spans t (several merged when the RT loop woke late): take the part
  // of its arc before t, leave the rest queued.
  if (steps_count_ > 0) {
    TimedStep& s = steps_[steps_head_];
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

OdometryStep Executive::odometry_pending() const {
  const std::size_t cap = std::max<std::size_t>(cfg_.odometry_history, 1);
  OdometryStep out = folded_;
  for (std::size_t i = 0; i < steps_count_; ++i) accumulate(&out, steps_[(steps_head_ + i) % cap].step);
  return out;
}

void Executive::process_scan(const lms::LmsScan& scan) {
  last_scan_.store(MonotonicClock::instance().now(), std::memory_order_release);
  ++scans_seen_;
  // Points in the robot frame, the laser's mount applied.
  std::size_t n = 0;
  const double min_r = cfg_.localmap.min_range_m, max_r = cfg_.localmap.max_range_m;
  for (std::size_t i = 0; i < scan.count; ++i) {
    const double r = scan.range_mm[i] * 1e-3;
    if (scan.range_mm[i] == 0 || r < min_r || r > max_r) continue;
    const double a = scan.angle_min + scan.angle_increment * static_cast<double>(i);
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
  snap_.scans = mapper_.counters().scans;
  snap_.matched = mapper_.counters().matched;

  // OdometryIncrement: the corrected motion since the previous scan and its covariance.
  cairn_OdometryIncrement inc{};
  inc.robot_id = cfg_.robot_id;
  inc.seq = ++odom_seq_;
  inc.t0_ns = last_odom_t_ ? last_odom_t_ : scan.stamp;
  inc.t1_ns = scan.stamp;
  last_odom_t_ = scan.stamp;
  to_msg(&inc.delta, u.increment);
  store_cov(inc.delta_cov, u.covariance);
  to_msg(&inc.local_pose, u.pose);
  if (!odometry_q_.push(inc)) publish_drops_.fetch_add(1, std::memory_order_relaxed);

  // Every Nth scan to the base station, with its corrected pose.
  if (scans_seen_ % static_cast<std::uint32_t>(cfg_.scan_publish_every) == 0) {
    cairn_LaserScan& m = *laser_msg_;
    m.robot_id = cfg_.robot_id;
    m.seq = ++laser_seq_;
    m.stamp_ns = scan.stamp;
    m.angle_min = static_cast<float>(scan.angle_min);
    m.angle_increment = static_cast<float>(scan.angle_increment);
    m.beam_period_s = static_cast<float>(scan.beam_period_s);
    m.n_beams = scan.count;
    std::memcpy(m.ranges_mm, scan.range_mm.data(), sizeof(std::uint16_t) * scan.count);
    std::memcpy(m.reflectivity, scan.flags.data(), scan.count);
    to_msg(&m.pose, compose(u.pose, cfg_.laser_mount));
    store_cov(m.pose_cov, u.covariance);
    to_msg(&m.sensor_offset, cfg_.laser_mount);
    if (!laser_q_.push(m)) publish_drops_.fetch_add(1, std::memory_order_relaxed);
  }

  // Retroreflective features.
  extract_features(scan, cfg_.laser_mount, cfg_.features, &features_);
  if (features_.count > 0) {
    cairn_FeatureObservations& f = *feature_msg_;
    f.robot_id = cfg_.robot_id;
    f.seq = ++feature_seq_;
    f.stamp_ns = scan.stamp;
    to_msg(&f.local_pose, u.pose);
    f.odom_seq = inc.seq;
    f.n_features = static_cast<std::uint8_t>(features_.count);
    for (std::size_t i = 0; i < features_.count; ++i) {
      const ScanFeature& s = features_.items[i];
      cairn_Feature& o = f.features[i];
      o.kind = s.robot ? cairn_FEATURE_ROBOT : cairn_FEATURE_LANDMARK;
      o.marker_id = -1;
      o.range = s.range;
      o.bearing = s.bearing;
      o.cov[0] = s.covariance(0, 0);
      o.cov[1] = o.cov[2] = s.covariance(0, 1);
      o.cov[3] = s.covariance(1, 1);
    }
    if (!feature_q_.push(f)) publish_drops_.fetch_add(1, std::memory_order_relaxed);
  }
}

}  // namespace cairn::firmware
