#include "hil/bench/robot_bench.hpp"

#include <unistd.h>

#include <stdexcept>

#include "drivers/can/socketcan_port.hpp"

namespace cairn::hil {

RobotBench::RobotBench(const World& world, const RobotBenchConfig& cfg, FleetBodies* bodies)
    : cfg_(cfg), bodies_(bodies), physics_world_(world), sensor_world_(world) {
  if (bodies_) {
    const Body mine = bodies_->body(cfg.robot_id);  // throws for a robot it lacks
    if (mine.radius != cfg.body_radius) {
      throw std::runtime_error("HIL bench: robot " + std::to_string(cfg.robot_id) + "'s shared body has another radius");
    }
    // A body elsewhere would be judged from where it is not until its first move.
    if ((mine.pose.translation() - cfg.start.translation()).norm() > 1e-9) {
      throw std::runtime_error("HIL bench: robot " + std::to_string(cfg.robot_id) + "'s shared body is not at its start pose");
    }
    // The others go into the sensor's world now, so that moving them later allocates nothing.
    others_.resize(bodies_->size());
    place_others();
  }
  const std::string path = cfg.bus_path.empty()
                               ? "/tmp/cairn-hil-can-" + std::to_string(getpid()) + "-" + std::to_string(cfg.robot_id)
                               : cfg.bus_path;
  if (cfg.can_iface.empty()) hub_ = std::make_unique<can::Hub>(path);
  std::string err;
  for (std::uint8_t node : {cfg.left_node, cfg.right_node}) {
    std::unique_ptr<can::Port> port;
    if (cfg.can_iface.empty()) {
      port = can::UcanPort::open(path, static_cast<std::uint16_t>(100 + node), false, &err);
    } else {
      port = can::SocketCanPort::open(cfg.can_iface, {}, &err);
    }
    if (!port) throw std::runtime_error("HIL bench: drive " + std::to_string(node) + ": " + err);
    DriveConfig dc;
    dc.node = node;
    drives_.push_back(std::make_unique<DriveRunner>(std::move(port), dc));
  }
  power_ = std::make_unique<PowerEmulator>(PowerEmulator::Link::kTcp, modbus::RegisterMap{}, BatteryConfig{});
  robot_ = std::make_unique<DiffRobot>(cfg.robot_id, cfg.geometry, cfg.start, cfg.body_radius, &physics_world_);
  robot_->set_wheel_scale(cfg.wheel_scale_left, cfg.wheel_scale_right);
  robot_->share_bodies(bodies_);
  truth_.pose = cfg.start;
  LmsDeviceConfig lms = cfg.lms;
  if (!cfg.lms_uart.empty()) {
    lms.power_on_baud = cfg.lms_uart_baud;
  } else if (cfg.lms_tcp) {
    lms.power_on_baud = cfg.lms_tcp_baud;
  }
  const LmsServer::Link link = !cfg.lms_uart.empty() ? LmsServer::Link::kUart
                               : cfg.lms_tcp           ? LmsServer::Link::kTcp
                                                       : LmsServer::Link::kPty;
  lms_ = std::make_unique<LmsServer>(link, lms, &sensor_world_, [this](Nanos) { return sensor_pose(); }, 0, cfg.lms_uart);
}

RobotBench::~RobotBench() { stop(); }

void RobotBench::start() {
  if (running_.exchange(true)) return;
  for (auto& d : drives_) d->start();
  lms_->start();
  thread_ = std::thread([this] { physics(); });
}

void RobotBench::stop() {
  if (!running_.exchange(false)) return;
  thread_.join();
  lms_->stop();
  for (auto& d : drives_) d->stop();
}

TruthSample RobotBench::truth() const {
  std::lock_guard l(mutex_);
  return truth_;
}

void RobotBench::place_others() {
  const std::size_t n = bodies_->snapshot_others(cfg_.robot_id, others_);
  for (std::size_t i = 0; i < n; ++i) sensor_world_.set_robot(others_[i].id, others_[i].pose, others_[i].radius);
}

// Called by the LMS device right before it casts a sweep against sensor_world_, on the LMS
// server's thread and under its lock (the only place sensor_world_ is touched once running).
Pose2 RobotBench::sensor_pose() {
  if (bodies_) place_others();
  std::lock_guard l(mutex_);
  return compose(truth_.pose, cfg_.laser_mount);
}

void RobotBench::physics() {
  auto& clock = MonotonicClock::instance();
  Nanos last = clock.now(), next = last;
  while (running_.load()) {
    next += 5 * kNanosPerMilli;
    clock.sleep_until(next);
    const Nanos now = clock.now();
    const double l = drives_[0]->with_node([](DriveNode& n) { return n.velocity(); });
    const double r = drives_[1]->with_node([](DriveNode& n) { return n.velocity(); });
    robot_->step(l, r, nanos_to_seconds(now - last));
    last = now;
    std::lock_guard lock(mutex_);
    truth_ = {now, robot_->pose(), robot_->odometer(), robot_->bumps(), robot_->robot_contacts()};
  }
}

}  // namespace cairn::hil
