// A CAN bus on simulated time with emulated CiA 402 drives on it, seen through the same
// can::Port interface the CANopen master uses on SocketCAN or the user-space hub. There are
// no threads: the master's own receive() waits move the SimClock, and the drives are
// advanced at a fixed tick meanwhile. So the master's logic (boot-up, heartbeat
// consumer, fault reset, bus-off recovery) runs deterministically, much faster than
// real time, and its bounds can be asserted to the tick instead of with scheduling slack.
// Every frame the master sends and every frame a drive sends is kept in a log with its
// simulated time, as a bus analyser would see it.
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "drivers/can/can_port.hpp"
#include "hil/cia402/drive_node.hpp"

namespace cairn::hil {

struct BusLogEntry {
  Nanos time = 0;
  can::Frame frame;
  bool from_master = false;
};

class SimDriveBus final : public can::Port {
 public:
  /// tick: how often the drives are advanced while the master waits (their time step).
  SimDriveBus(SimClock* clock, std::vector<DriveConfig> drives, Nanos tick = 100 * kNanosPerMicro);

  can::SendResult send(const can::Frame& f, Nanos deadline) override;
  bool receive(can::Frame* f, Nanos timeout) override;
  const can::BusStats& stats() const override { return stats_; }
  bool bus_off() const override { return bus_off_; }
  IoError restart() override;
  std::string describe() const override { return "simulated CAN bus (" + std::to_string(nodes_.size()) + " drives)"; }
  void pause(Nanos until) override { run_until(until); }  // the drives go on meanwhile

  DriveNode& drive(std::size_t i) { return *nodes_[i]; }
  std::size_t drives() const { return nodes_.size(); }
  /// The master's controller goes bus-off now (an error frame tells it) and stays off the
  /// bus until `hold` has passed; a restart before that fails as the hub's does.
  void inject_bus_off(Nanos hold);
  /// Advances the drives (and the clock) to `t` without the master: time the master spent
  /// elsewhere.
  void run_until(Nanos t);
  const std::deque<BusLogEntry>& log() const { return log_; }
  void clear_log() { log_.clear(); }

 private:
  void advance_to(Nanos t);
  void collect(Nanos now);

  SimClock* clock_;
  Nanos tick_;
  std::vector<std::unique_ptr<DriveNode>> nodes_;
  std::deque<can::Frame> to_master_;
  std::deque<BusLogEntry> log_;
  can::BusStats stats_;
  bool bus_off_ = false;
  Nanos hold_until_ = 0;
};

}  // namespace cairn::hil
