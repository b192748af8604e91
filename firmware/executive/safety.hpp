// The robot's safety supervisor, evaluated once per RT cycle on plain inputs: any stop
// condition forces zero velocity with a reason; otherwise the requested velocity is
// clamped to the limits and rate-limited to the acceleration limits. Pure.
#pragma once

#include <cstdint>

#include "common/clock.hpp"

namespace cairn::firmware {

// RobotStatus.stop_reason codes (docs/firmware.md).
enum class StopReason : std::uint8_t {
  kNone = 0,
  kEstop = 1,            // the power board's e-stop input
  kDrivesNotReady = 2,   // a drive is not operation enabled (booting, fault, heartbeat lost)
  kLinkLost = 3,         // no PoseCorrection / TaskAssignment within the link timeout
  kLaserLost = 4,        // no scan within the laser timeout
  kCommandStale = 5,     // the velocity source went silent
  kPowerLost = 6,        // the power board does not answer
};
const char* stop_reason_text(StopReason r);

struct SafetyLimits {
  double max_v = 0.8, max_w = 1.5;       // m/s, rad/s
  double max_acc = 0.8, max_alpha = 2.0; // m/s², rad/s²
  Nanos link_timeout = 2 * kNanosPerSecond;   // 0 = no base-station link required
  Nanos laser_timeout = 500 * kNanosPerMilli;
  Nanos command_timeout = 500 * kNanosPerMilli;
  Nanos power_timeout = 1 * kNanosPerSecond;
};

struct SafetyInputs {
  Nanos now = 0;
  bool estop = false;
  bool drives_enabled = false;
  Nanos last_link = -1;     // -1: never heard
  Nanos last_scan = -1;
  Nanos last_command = -1;
  Nanos last_power = -1;
  double v = 0, w = 0;      // requested
};

class SafetySupervisor {
 public:
  explicit SafetySupervisor(const SafetyLimits& l) : limits_(l) {}
  /// Returns the reason (kNone when moving is allowed) and writes the velocity to apply.
  StopReason evaluate(const SafetyInputs& in, double dt, double* v, double* w);
  StopReason reason() const { return reason_; }
  std::uint64_t stops() const { return stops_; }

 private:
  SafetyLimits limits_;
  double v_ = 0, w_ = 0;
  StopReason reason_ = StopReason::kNone;
  std::uint64_t stops_ = 0;
};

}  // namespace cairn::firmware
