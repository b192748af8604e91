// An emulated CiA 402 servo drive on CANopen: object dictionary with an SDO server
// (expedited; segmented upload of the device name), NMT (boot-up, pre-operational,
// operational, reset), heartbeat producer (0x1017), PDOs mapped through the object
// dictionary (0x1400/0x1600 RPDO1, 0x1800/0x1A00 TPDO1, 0x1801/0x1A01 TPDO2; factory
// mapping: canopen::pdo_map::kDrive, the master's) exchanged on SYNC, EMCY, and the
// 402 power state machine driven by the controlword. In operation enabled the motor
// follows the target velocity (0x60FF, increments/s) within the profile acceleration
// (0x6083) and integrates the encoder position (0x6064).
// Pure model: frames and time in, frames out (a runner connects it to a CAN port).
// Faults: over-current (EMCY 0x2310, fault until reset), silence, the HALT-bit quirk.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "drivers/canopen/canopen_codec.hpp"
#include "drivers/canopen/cia402.hpp"
#include "drivers/canopen/object_dictionary.hpp"
#include "drivers/canopen/pdo_map.hpp"

namespace cairn::hil {

struct DriveConfig {
  std::uint8_t node = 1;
  double boot_time_s = 0.1;
  std::int32_t max_velocity = 200000;  // increments/s
  std::string name = "Cairn emulated CiA 402 drive";
  bool reject_halt = false;            // quirk: a controlword with HALT (bit 8) faults the drive
  double sync_loss_s = 0.1;            // operational and no SYNC this long: stop the motor (0 = never)
};

class DriveNode {
 public:
  explicit DriveNode(DriveConfig cfg);

  void power_on(Nanos now);
  void on_frame(const canopen::Frame& f, Nanos now);
  /// Advances time (motor, heartbeat). Frames to send are queued in outbox().
  void update(Nanos now);
  std::deque<canopen::Frame>& outbox() { return out_; }

  // Faults.
  void over_current(Nanos now);
  void set_silent(bool s) { silent_ = s; }
  /// Garbage on the bus: foreign frames, and malformed frames on this node's own COB-IDs
  /// (a TPDO, heartbeat, EMCY or SDO response of the wrong length) that decoders must reject.
  void inject_garbage(std::size_t n, std::uint64_t seed);
  bool silent() const { return silent_; }

  // Observation (tests, the simulated robot).
  cia402::State state() const { return state_; }
  canopen::NmtState nmt() const { return nmt_; }
  double velocity() const { return velocity_; }      // increments/s
  std::int64_t position() const { return static_cast<std::int64_t>(position_); }
  std::int32_t target_velocity() const { return static_cast<std::int32_t>(od(canopen::od::kTargetVelocity, 0)); }
  std::uint64_t syncs() const { return syncs_; }
  /// An object's value (0 if the drive has no such object), as an SDO upload would read it
  /// (except the statusword, which is refreshed only when read or sent).
  std::uint32_t od(std::uint16_t index, std::uint8_t sub) const;
  /// When the drive last left operation enabled (torque off) on a controlword it received
  /// (RPDO or SDO) or on SYNC loss; 0 = never.
  Nanos torque_off_at() const { return torque_off_at_; }
  /// When an RPDO last changed the target velocity from non-zero to zero; 0 = never.
  Nanos zero_target_at() const { return zero_target_at_; }
  bool sync_lost() const { return sync_lost_; }

 private:
  struct Entry {
    std::uint32_t value = 0;
    std::uint8_t size = 4;   // bytes
    bool writable = true;
  };
  void set_od(std::uint16_t index, std::uint8_t sub, std::uint32_t v);
  void reset_communication();
  void handle_sdo(const canopen::Frame& f);
  void handle_controlword(std::uint16_t cw);
  void handle_rpdo1(const canopen::Frame& f);
  std::uint16_t statusword() const;
  void send(const canopen::Frame& f) {
    if (!silent_) out_.push_back(f);
  }
  void send_tpdo(unsigned k);  // k = 0: TPDO1

  DriveConfig cfg_;
  std::map<std::uint32_t, Entry> od_;  // key: index << 8 | sub
  std::deque<canopen::Frame> out_;
  canopen::NmtState nmt_ = canopen::NmtState::kBootUp;
  cia402::State state_ = cia402::State::kNotReadyToSwitchOn;
  bool booted_ = false;
  Nanos boot_at_ = 0, last_update_ = 0, next_heartbeat_ = 0;
  std::uint16_t last_cw_ = 0;
  double velocity_ = 0, position_ = 0;
  bool silent_ = false;
  std::uint64_t syncs_ = 0;
  Nanos last_sync_ = 0;
  bool sync_lost_ = false;
  Nanos torque_off_at_ = 0, zero_target_at_ = 0;
  // Segmented upload state (device name).
  std::string upload_;
  std::size_t upload_off_ = 0;
  bool upload_toggle_ = false;
};

}  // namespace cairn::hil
