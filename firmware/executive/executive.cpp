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

}  // namespace

Executive::Executive(const ExecutiveConfig& cfg, Clock& clock, ExecutiveDevices devices, ThreadHooks hooks)
    : cfg_(cfg),
      clock_(clock),
      dev_(std::move(devices)),
      hooks_(hooks),
      scan_q_(cfg.scan_queue),
      odometry_q_(cfg.odometry_queue),
      laser_q_(cfg.laser_queue),
      feature_q_(cfg.feature_queue),
      core_([&] {
        ExecutiveConfig c = cfg;
        c.localmap.async_rebuild = true;  // the map worker thread builds the field
        return c;
      }()),
      scan_work_(std::make_unique<lms::LmsScan>()) {
  if (!dev_.laser || !dev_.can || !dev_.power) throw std::invalid_argument("executive: a device is missing");
  master_ = std::make_unique<canopen::DriveMaster>(dev_.can.get(), &clock_, cfg.master);
  sink_.self = this;
  outputs_.self = this;
  (void)logger();  // the RT-safe logger's ring is allocated here, not on first use in a thread
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
  threads_[4] = std::thread([this] { map_worker_thread(); });
}

void Executive::stop() {
  if (!running_.exchange(false)) return;
  for (auto& t : threads_)
    if (t.joinable()) t.join();
}

void Executive::set_velocity(double v, double w, Nanos now) { velocity_.write({v, w, now}); }

bool Executive::request_reset(std::uint32_t remote_stops_seen) {
  if (remote_stops_seen < remote_stops_.load(std::memory_order_acquire)) {
    resets_predating_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  request_reset();
  return true;
}

void Executive::request_remote_stop() {
  master_->request_estop();  // torque off now: no RT hop
  motor_power_want_.store(false, std::memory_order_release);
  remote_stops_.fetch_add(1, std::memory_order_acq_rel);
}

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
  // A full queue counts the overflow; the RT loop reports it.
  if (self->scan_q_.push(s)) self->scan_event_.notify();  // the RT thread processes it now
}

void Executive::lms_thread() {
  rt_reports_[0] = "lms: " + apply_rt(cfg_.io_threads);
  Clock& clock = clock_;
  lms::LmsDriver driver(dev_.laser.get(), &clock, cfg_.lms, &sink_);
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
  Clock& clock = clock_;
  if (hooks_.steady) hooks_.steady("can");
  Nanos next_snapshot = 0;
  std::array<DeviceSnapshot, 2> d;
  copy_text(&d[0].name, "drive_left");
  copy_text(&d[1].name, "drive_right");
  canopen::WheelCommand cmd;
  std::uint64_t updates = 0;
  Nanos wheel_stamp = 0;
  std::array<std::uint64_t, 2> drive_updates{};
  std::array<Nanos, 2> drive_fresh{-1, -1};  // when each drive's newest TPDO arrived
  while (running_.load(std::memory_order_relaxed)) {
    if (enable_request_.exchange(false)) master_->enable_all();
    master_->step();
    wheel_cmd_.read(&cmd);
    const std::int32_t velocities[2] = {cmd.left, cmd.right};
    master_->command(velocities);
    const auto& l = master_->feedback(0);
    const auto& r = master_->feedback(1);
    const Nanos pass = clock.now();
    // Written every pass (the enabled flag and the pass stamp matter even without new
    // positions); the stamp moves only when new positions arrive.
    if (l.updates + r.updates != updates) {
      updates = l.updates + r.updates;
      wheel_stamp = pass;
    }
    for (std::size_t i = 0; i < 2; ++i) {
      if (master_->feedback(i).updates != drive_updates[i]) {
        drive_updates[i] = master_->feedback(i).updates;
        drive_fresh[i] = pass;
      }
    }
    const Nanos feedback = drive_fresh[0] < 0 || drive_fresh[1] < 0 ? -1 : std::min(drive_fresh[0], drive_fresh[1]);
    wheels_.write({l.position, r.position, updates, master_->all_enabled(), wheel_stamp, feedback, pass});
    const Nanos now = clock.now();
    if (now >= next_snapshot) {
      next_snapshot = now + 100 * kNanosPerMilli;
      const auto& bus = dev_.can->stats();
      for (std::size_t i = 0; i < 2; ++i) {
        d[i].state = static_cast<std::uint8_t>(master_->phase(i));
        copy_text(&d[i].reason, canopen::phase_name(master_->phase(i)));
        d[i].frames = static_cast<std::uint32_t>(master_->feedback(i).updates);
        d[i].recoveries = static_cast<std::uint32_t>(master_->recoveries() + bus.restarts);  // fault resets, bus restarts
        d[i].errors = static_cast<std::uint32_t>(bus.error_frames + bus.bus_off + master_->send_failures() +
                                                 master_->restart_failures());
        d[i].timeouts = static_cast<std::uint32_t>(master_->last_emcy(i));
        device_box_[1 + i].write(d[i]);
      }
    }
  }
  master_->disable_all("shutdown");
  if (hooks_.finished) hooks_.finished("can");
}

// ---- power-board I/O thread ----------------------------------------------------------
//
// One Modbus link, one thread, a fixed cycle (estop_poll): each cycle first reads the
// e-stop and reset inputs (the fast path, one short transaction), acts on a press at once
// (the drive master's lock-free request_estop(), then motor power off), and then does at
// most one other transaction: the motor relay when it must change, else the battery poll
// when due. So an e-stop read waits behind at most one short transaction, never behind a
// full poll; every transaction is bounded by the response timeout.

void Executive::power_thread() {
  rt_reports_[2] = "power: " + apply_rt(cfg_.io_threads);
  Clock& clock = clock_;
  modbus::PowerLink& power = *dev_.power;
  modbus::PowerFault poll_fault, relay_fault;
  modbus::PowerState ps;
  DeviceSnapshot d;
  copy_text(&d.name, "power");
  if (hooks_.steady) hooks_.steady("power");
  Nanos next_cycle = clock.now(), next_poll = 0, next_snapshot = 0;
  bool last_reset = false, poll_ok = false;
  int relay = -1;        // what the relay coil was last written to (-1: unknown / the write failed)
  int last_target = -1;  // what the last write tried to set
  while (running_.load(std::memory_order_relaxed)) {
    // 1. The fast path.
    modbus::SafetyInputBits in;
    if (power.read_safety_inputs(&in)) {
      if (in.estop) {
        if (!estop_.exchange(true, std::memory_order_acq_rel)) {
          master_->request_estop();  // torque off at once: no RT hop
          motor_power_want_.store(false, std::memory_order_release);  // off until a reset (below, this cycle)
          estop_presses_.fetch_add(1, std::memory_order_acq_rel);      // the RT loop latches even a short press
        }
      } else {
        estop_.store(false, std::memory_order_release);
      }
      last_power_.store(clock.now(), std::memory_order_release);
      if (in.reset && !last_reset) reset_requests_.fetch_add(1, std::memory_order_acq_rel);  // the button's rising edge
      last_reset = in.reset;
    }  // a failed read is counted by the link; no good read for power_timeout stops and latches (RT loop)
    // 2. At most one other transaction: the motor relay when it must change, else the
    // poll. A retry of a write that failed (a silent board) gives way to a due poll, so it
    // cannot starve the poll; a new target (off on an e-stop) always goes first.
    const Nanos now = clock.now();
    const bool want = motor_power_want_.load(std::memory_order_acquire) && !estop_.load(std::memory_order_acquire);
    const int target = want ? 1 : 0;
    const bool poll_due = now >= next_poll;
    const bool retry = relay == -1 && last_target == target;
    if (relay != target && !(retry && poll_due)) {
      last_target = target;
      relay = power.set_motor_power(want, &relay_fault) ? target : -1;
    } else if (poll_due) {
      next_poll = now + cfg_.power_poll;
      poll_ok = power.poll(&ps, &poll_fault);
      if (poll_ok) power_state_.write(ps);
    }
    if (now >= next_snapshot) {
      next_snapshot = now + 100 * kNanosPerMilli;
      const auto& c = power.counters();
      d.state = poll_ok && relay != -1 ? 1 : 0;
      if (!poll_ok) {
        poll_fault.format(d.reason.data(), d.reason.size());
      } else if (relay == -1) {
        relay_fault.format(d.reason.data(), d.reason.size());
      } else {
        copy_text(&d.reason, relay == 1 ? "ok, motor power on" : "ok, motor power off");
      }
      d.frames = static_cast<std::uint32_t>(c.polls + c.input_reads);
      d.timeouts = static_cast<std::uint32_t>(c.timeouts);
      d.recoveries = static_cast<std::uint32_t>(c.reconnects);
      d.errors = static_cast<std::uint32_t>(c.errors + c.invalid);
      device_box_[3].write(d);
    }
    next_cycle += cfg_.estop_poll;
    const Nanos after = clock.now();
    if (next_cycle < after) next_cycle = after;  // a slow transaction: read again at once, no burst
    clock.sleep_until(next_cycle);
  }
  if (hooks_.finished) hooks_.finished("power");
}

// ---- RT loop -------------------------------------------------------------------------

void Executive::rt_thread() {
  rt_reports_[3] = "rt: " + apply_rt(cfg_.rt_loop);
  Clock& clock = clock_;
  LoopStats stats(cfg_.period);
  WorkStats scan_work;
  if (hooks_.steady) hooks_.steady("rt");
  Nanos deadline = clock.now() + cfg_.period;
  const double dt = nanos_to_seconds(cfg_.period);
  while (running_.load(std::memory_order_relaxed)) {
    // Wake on a scan (processed at once) or at the control deadline, whichever is first.
    const std::uint32_t seen = scan_event_.value();
    if (scan_q_.front() == nullptr) clock.wait_event(scan_event_, seen, deadline);
    // The wheels first: a scan takes the odometry up to its mid-sweep.
    WheelReading ws;
    if (wheels_.read(&ws)) core_.on_wheels(ws);
    // Then the control cycle when it is due, before any scan: a scan's matching (a few ms
    // at most, bounded by the configuration check) must not delay the wheel commands.
    const Nanos wake = clock.now();
    if (wake >= deadline) {
      control_cycle(wake, dt);
      const Nanos done = clock.now();
      stats.record(wake, deadline, done);
      snap_.period_mean_us = static_cast<float>(stats.mean_us());
      snap_.period_p99_us = static_cast<float>(stats.p99_us());
      snap_.jitter_max_us = static_cast<float>(stats.max_jitter_us());
      snap_.scan_work_p99_us = static_cast<float>(scan_work.p99_us());
      snap_.scan_work_max_us = static_cast<float>(scan_work.max_us());
      snap_.cycles = stats.cycles();
      snap_.misses = stats.misses();
      snap_.first_misses = stats.miss_log();
      rt_box_.write(snap_);
      deadline += cfg_.period;
      if (done > deadline) deadline = done + cfg_.period;  // overran: skip, do not burst
    }
    // Scans: at most two per wake (the laser makes < 1 per 10 ms); the rest wait.
    for (int k = 0; k < 2 && scan_q_.pop(scan_work_.get()); ++k) {
      const Nanos begin = clock.now();
      core_.on_scan(*scan_work_, begin, outputs_);
      if (core_.mapper().rebuild_requested()) rebuild_event_.notify();  // a keyframe: the worker builds
      scan_work.record(clock.now() - begin);
    }
  }
  // Leave the wheels commanded to zero.
  wheel_cmd_.write({});
  if (hooks_.finished) hooks_.finished("rt");
}

// ---- map worker: the keyframe rebuild off the RT thread -------------------------------

void Executive::map_worker_thread() {
  rt_reports_[4] = "map worker: " + apply_rt(cfg_.map_worker);
  Clock& clock = clock_;
  if (hooks_.steady) hooks_.steady("map");
  localmap::LocalMapper& mapper = core_.mapper();  // only build_pending() here (its threading contract)
  while (running_.load(std::memory_order_relaxed)) {
    const std::uint32_t seen = rebuild_event_.value();
    if (!mapper.build_pending()) clock.wait_event(rebuild_event_, seen, clock.now() + 50 * kNanosPerMilli);
  }
  if (hooks_.finished) hooks_.finished("map");
}

void Executive::control_cycle(Nanos now, double dt) {
  const bool estop = estop_.load(std::memory_order_acquire);
  const std::uint32_t resets = reset_requests_.load(std::memory_order_acquire);
  const std::uint32_t presses = estop_presses_.load(std::memory_order_acquire);
  const bool pressed_since = presses != presses_seen_;  // a press shorter than a cycle still latches
  presses_seen_ = presses;
  Velocity cmd;
  velocity_.read(&cmd);
  ControlInputs in;
  in.now = now;
  in.estop = estop || pressed_since;
  in.last_link = last_link_.load(std::memory_order_acquire);
  in.last_power = last_power_.load(std::memory_order_acquire);
  in.v = cmd.v;
  in.w = cmd.w;
  in.command_stamp = cmd.stamp;
  in.reset = resets != resets_seen_;
  resets_seen_ = resets;
  const std::uint32_t remote = remote_stops_.load(std::memory_order_acquire);
  in.remote_stop = remote != remote_stops_seen_;
  remote_stops_seen_ = remote;
  wheel_cmd_.write(core_.control(in, dt));
  // The latch: set, the drives are disabled and motor power goes off (a press already did
  // both from the power thread; a lost input or a stalled CAN thread does it here). Only
  // an accepted reset switches motor power on and lets the drive master enable again.
  const SafetySupervisor& safety = core_.safety();
  if (safety.latched() && !was_latched_) {
    master_->request_estop();
    motor_power_want_.store(false, std::memory_order_release);
    CAIRN_LOG_WARN("safety", "latched: {}; drives disabled, motor power off until a reset", latch_cause_text(safety.latch_cause()));
  }
  if (safety.reset_accepted() && remote_stops_.load(std::memory_order_acquire) != remote_stops_seen_) {
    // A remote e-stop arrived while this cycle accepted the reset: its bridge thread has
    // already switched motor power off and asked the drives to stop; power stays off and the
    // drives stay disabled, and the next cycle latches again.
    CAIRN_LOG_WARN("safety", "reset overtaken by a remote e-stop in the same cycle: staying stopped");
  } else if (safety.reset_accepted()) {
    motor_power_want_.store(true, std::memory_order_release);
    enable_request_.store(true, std::memory_order_release);
    CAIRN_LOG_INFO("safety", "reset accepted: motor power on, enabling the drives");
  } else if (in.reset && safety.latched()) {
    CAIRN_LOG_WARN("safety", "reset refused: {}", stop_reason_text(core_.stop()));
  }
  was_latched_ = safety.latched();

  modbus::PowerState ps;
  power_state_.read(&ps);
  const CoreCounters c = core_.counters();
  snap_.stop = core_.stop();
  snap_.v = core_.v();
  snap_.w = core_.w();
  snap_.field_nearest = core_.field().nearest;
  snap_.field_limited = core_.field().limited;
  snap_.estop = estop;
  snap_.latched = safety.latched();
  snap_.latch_cause = safety.latch_cause();
  snap_.motor_power = motor_power_want_.load(std::memory_order_relaxed) && !estop;
  snap_.resets_accepted = safety.resets_accepted();
  snap_.resets_refused = safety.resets_refused();
  snap_.remote_stops = remote_stops_.load(std::memory_order_acquire);
  snap_.resets_predating = resets_predating_.load(std::memory_order_relaxed);
  snap_.stops = core_.stops();
  snap_.scans = c.scans;
  snap_.matched = c.matched;
  snap_.battery_voltage = ps.voltage;
  snap_.battery_soc = ps.soc;
  snap_.local_pose = core_.local_pose();
  snap_.overflows = scan_q_.overflows() + odometry_q_.overflows() + laser_q_.overflows() + feature_q_.overflows();
}

void Executive::QueueOutputs::odometry(const msg::OdometryIncrement& m) {
  if (!self->odometry_q_.push(m)) self->publish_drops_.fetch_add(1, std::memory_order_relaxed);
  self->output_event_.notify();
}

void Executive::QueueOutputs::laser(const msg::LaserScan& m) {
  if (!self->laser_q_.push(m)) self->publish_drops_.fetch_add(1, std::memory_order_relaxed);
  self->output_event_.notify();
}

void Executive::QueueOutputs::features(const msg::FeatureObservations& m) {
  if (!self->feature_q_.push(m)) self->publish_drops_.fetch_add(1, std::memory_order_relaxed);
  self->output_event_.notify();
}

}  // namespace cairn::firmware
