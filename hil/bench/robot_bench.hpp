// One simulated robot on the HIL bench: a world, the robot's body (moved by its two
// CiA 402 drive emulators on a user-space CAN bus), its LMS2xx emulator (scanning from the
// body's true pose through the laser mount) and its power-board emulator. The production
// firmware connects to lms_uri(), can_uri() and power_uri() exactly as to real devices.
// Physics runs in its own thread at 200 Hz; the true pose is kept for the tests.
// Given FleetBodies (one world for several benches), the body also stops at the other
// robots' bodies and the laser sees them where they stand at each scan.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/can/can_hub.hpp"
#include "hil/cia402/drive_runner.hpp"
#include "hil/lms2xx/lms_server.hpp"
#include "hil/power/power_emulator.hpp"
#include "hil/robot/diff_robot.hpp"
#include "hil/world/fleet_bodies.hpp"
#include "hil/world/world.hpp"

namespace cairn::hil {

struct RobotBenchConfig {
  int robot_id = 1;
  Pose2 start{1.5, 10.0, 0.0};
  std::string bus_path;                       // the CAN hub's socket ("" = a fresh one in /tmp)
  Pose2 laser_mount{0.2, 0.0, 0.0};
  double body_radius = 0.3;
  double wheel_scale_left = 1.01, wheel_scale_right = 0.995;  // true radius / nominal: odometry drifts
  canopen::DiffDriveGeometry geometry;
  LmsDeviceConfig lms;
  bool lms_tcp = false;                       // serve the laser on TCP instead of a pty
  std::uint32_t lms_tcp_baud = 500000;        // TCP: the device server's fixed line rate, which
                                              // the laser is permanently set to
  std::uint8_t left_node = 1, right_node = 2;
  // The VM bench's real devices (scripts/vm-bench.sh): the drives on a SocketCAN interface
  // instead of the user-space hub, and the laser on a UART whose other end (lms_host_uri,
  // e.g. serial:/dev/ttyS1) the robot opens. Empty: the hub and a pty (or TCP).
  std::string can_iface;
  // qemu's UARTs pass bytes whatever rates the two ends are set to, so a rate mismatch
  // cannot be emulated there (the pty can): the laser sits at lms_uart_baud from power-on,
  // as it does at lms_tcp_baud on a device server.
  std::string lms_uart, lms_host_uri;
  std::uint32_t lms_uart_baud = 38400;
};

struct TruthSample {
  Nanos t = 0;
  Pose2 pose;
  double odometer = 0;
  std::uint64_t wall_bumps = 0;      // physics steps blocked by the world's obstacles
  std::uint64_t robot_contacts = 0;  // ... by another robot's body (shared world only)
};

class RobotBench {
 public:
  /// `bodies` (may be null: the robot is alone in its world) holds this robot's body (at
  /// cfg.start, of cfg.body_radius) and the others', shared with their benches; it must
  /// outlive this bench.
  RobotBench(const World& world, const RobotBenchConfig& cfg, FleetBodies* bodies = nullptr);
  ~RobotBench();
  void start();
  void stop();

  std::string lms_uri() const { return cfg_.lms_uart.empty() ? lms_->uri() : cfg_.lms_host_uri; }
  std::string can_uri() const { return hub_ ? hub_->uri() : "socketcan:" + cfg_.can_iface; }
  std::string power_uri() const { return power_->uri(); }

  TruthSample truth() const;
  LmsServer& lms() { return *lms_; }
  PowerEmulator& power() { return *power_; }
  DriveRunner& drive(int i) { return *drives_[static_cast<std::size_t>(i)]; }

 private:
  void physics();
  Pose2 sensor_pose();
  void place_others();  // the other bodies, where they stand now, into sensor_world_
  RobotBenchConfig cfg_;
  FleetBodies* bodies_;
  // The sensor's copy is only touched by the LMS server's thread under its lock: the
  // other robots are placed in it there, just before each sweep is cast.
  World physics_world_, sensor_world_;
  std::vector<Body> others_;  // sized at construction: placing them allocates nothing
  std::unique_ptr<can::Hub> hub_;
  std::vector<std::unique_ptr<DriveRunner>> drives_;
  std::unique_ptr<PowerEmulator> power_;
  std::unique_ptr<LmsServer> lms_;
  std::unique_ptr<DiffRobot> robot_;
  mutable std::mutex mutex_;
  TruthSample truth_;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace cairn::hil
