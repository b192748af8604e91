// Several robots' benches in one world, served to other processes: for each robot, its
// emulated LMS2xx, CiA 402 drives and power board (hil/bench/robot_bench.hpp), a robot
// configuration written from a template with the emulators' URIs and the robot's route
// (taken into its local frame), a ground-truth log, and scheduled device faults. With
// shared_world the robots share one set of bodies (hil/world/fleet_bodies.hpp): they see
// each other with their lasers and stop at each other; contacts are reported.
#pragma once

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "hil/bench/robot_bench.hpp"

namespace cairn::hil {

enum class FaultKind { kEstop, kLaserUnplug, kDriveSilent, kPowerSilent };

/// "T:ROBOT:KIND[:DURATION]", e.g. "20:1:estop:2" (seconds from start; kinds estop,
/// laser, drive, power; default duration 2 s). Throws std::invalid_argument with the reason.
struct ScheduledFault {
  double at_s = 0;
  int robot = 1;
  FaultKind kind = FaultKind::kEstop;
  double duration_s = 2.0;
  static ScheduledFault parse(const std::string& text);
};
const char* fault_name(FaultKind k);

struct FleetBenchConfig {
  std::vector<int> robots{1};        // ids; each needs a `start` in the world
  std::string robot_template;         // robot TOML whose robot/devices/motion are filled in
  std::string out_dir;                // where robot-<id>.toml is written
  bool lms_tcp = false;
  // The VM bench's real devices, for a fleet of one (RobotBenchConfig says what they are).
  std::string can_iface, lms_uart, lms_host_uri;
  std::uint32_t lms_uart_baud = 38400;
  std::vector<ScheduledFault> faults;
  bool shared_world = false;          // one world: robots see and stop at each other
};

/// Contacts between two robots so far (shared world).
struct RobotContacts {
  int a = 0, b = 0;
  std::uint64_t contacts = 0;       // separate touches
  std::uint64_t refused_moves = 0;  // physics steps refused (either robot pushing)
};

class FleetBench {
 public:
  /// Builds every robot's bench; throws std::runtime_error naming what is missing.
  FleetBench(const World& world, const FleetBenchConfig& cfg);
  ~FleetBench();
  void start();
  void stop();
  /// Writes robot-<id>.toml for every robot; returns the paths, in robot order.
  std::vector<std::string> write_robot_configs() const;
  /// Applies due faults (and their ends); returns a line per change ("" none).
  std::vector<std::string> apply_faults(double t_s);
  /// Appends one truth line per robot: "t_s id x y theta odometer_m".
  void write_truth(std::FILE* out, double t_s) const;
  /// Shared world: every pair of robots that came into contact since the last call
  /// (none without a shared world).
  std::vector<RobotContacts> new_contacts();
  /// Shared world: every pair that ever touched, with totals.
  std::vector<RobotContacts> contacts() const;
  std::size_t size() const { return benches_.size(); }
  int id(std::size_t i) const { return cfg_.robots[i]; }
  RobotBench& bench(std::size_t i) { return *benches_[i]; }
  /// The robot's scripted route in its local frame (start pose = origin).
  std::vector<Vec2> local_route(std::size_t i) const;

 private:
  void set_fault(const ScheduledFault& f, bool on);
  const World& world_;
  FleetBenchConfig cfg_;
  std::unique_ptr<FleetBodies> bodies_;  // shared world only; outlives the benches
  std::vector<std::unique_ptr<RobotBench>> benches_;
  template <class F>
  void for_each_pair(F&& f) const;  // f(pair index, its contacts), robots i < j in config order
  std::vector<std::uint64_t> contacts_seen_;  // per pair (i < j, row-major), for new_contacts()
  std::vector<int> fault_state_;  // 0 pending, 1 active, 2 over
};

}  // namespace cairn::hil
