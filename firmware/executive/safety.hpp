// The robot's safety supervisor, evaluated once per RT cycle on plain inputs: any stop
// condition forces zero velocity with a reason; otherwise the requested velocity is
// clamped to the limits and rate-limited to the acceleration limits. Pure (no clock, no
// devices): time and inputs arrive with every call, so it is tested on simulated time.
//
// The e-stop latches (EN ISO 13850): a pressed e-stop, a lost e-stop input (no good read
// of the power board within power_timeout, once it has answered), a stalled CAN thread
// (its zero command can no longer reach the drives) or an operator's remote e-stop (the
// base's SafetyStop, a momentary press from afar) sets the latch; it stays set after
// the cause is gone, with the drives disabled and motor power off, until an explicit
// reset (a DDS SafetyReset from the base, SIGUSR1 to cairn-robot, or the board's reset
// input). A reset is accepted only when the e-stop reads released, the input is fresh and
// the CAN thread cycles; a refused reset is counted and forgotten (never acted on later).
//
// The protective field is a speed limit, not a latch: forward speed is held to what the
// robot can stop from before the nearest return on its path (the turn rate scaled with it,
// keeping the path's curvature). Blocked (nothing allowed) with forward motion requested,
// or already faster than braking at max_acc from now can stop in time (something stepped
// in: the reaction-time budget is gone), it stops at once with kProtectiveField; it clears
// when the path is free.
#pragma once

#include <cstdint>
#include <limits>

#include "common/clock.hpp"
#include "common/stop_reason.hpp"

namespace cairn::firmware {

// RobotStatus.stop_reason codes: common/stop_reason.hpp.
using cairn::StopReason;
using cairn::stop_reason_text;

/// Why the latch is set (the first cause since the last reset).
enum class LatchCause : std::uint8_t { kNone = 0, kEstop = 1, kEstopInputLost = 2, kCanStalled = 3, kRemoteStop = 4 };
const char* latch_cause_text(LatchCause c);

struct SafetyLimits {
  double max_v = 0.8, max_w = 1.5;       // m/s, rad/s
  double max_acc = 0.8, max_alpha = 2.0; // m/s², rad/s²
  Nanos link_timeout = 2 * kNanosPerSecond;   // 0 = no base-station link required
  Nanos laser_timeout = 500 * kNanosPerMilli;
  Nanos command_timeout = 500 * kNanosPerMilli;
  /// No good read of the e-stop input this long: stop and latch (<= 100 ms, validated).
  Nanos power_timeout = 50 * kNanosPerMilli;
  /// An enabled drive's newest TPDO older than this, or the CAN thread silent this long:
  /// stop (the latter also latches and cuts motor power). <= 100 ms, validated.
  Nanos feedback_timeout = 50 * kNanosPerMilli;
};

struct SafetyInputs {
  Nanos now = 0;
  bool estop = false;       // the last good read of the e-stop input
  bool drives_enabled = false;
  Nanos last_link = -1;     // -1: never heard
  Nanos last_scan = -1;
  Nanos last_command = -1;
  Nanos last_power = -1;    // the last good read of the e-stop input
  Nanos last_feedback = -1; // the oldest of the drives' newest TPDO arrivals
  Nanos last_can_pass = -1; // the CAN thread's last pass (-1: not started yet)
  bool reset = false;       // a reset was requested since the last cycle
  bool remote_stop = false; // a remote e-stop arrived since the last cycle (a reset in the same cycle is refused)
  double v = 0, w = 0;      // requested
  // The protective field's limits for the requested arc (protective_field.hpp): forward
  // speed it can stop from (0: blocked) and the reverse cap.
  double field_forward_max_v = std::numeric_limits<double>::infinity();
  double field_brake_max_v = std::numeric_limits<double>::infinity();  // stops braking now, no reaction time
  double field_reverse_max_v = std::numeric_limits<double>::infinity();
};

class SafetySupervisor {
 public:
  explicit SafetySupervisor(const SafetyLimits& l) : limits_(l) {}
  /// Returns the reason (kNone when moving is allowed) and writes the velocity to apply.
  StopReason evaluate(const SafetyInputs& in, double dt, double* v, double* w);
  StopReason reason() const { return reason_; }
  std::uint64_t stops() const { return stops_; }
  /// The e-stop latch: set, the drives must be disabled and motor power off.
  bool latched() const { return latched_; }
  LatchCause latch_cause() const { return cause_; }
  /// True for the one evaluate() that accepted a reset (the caller enables the drives and
  /// switches motor power on).
  bool reset_accepted() const { return reset_accepted_; }
  std::uint64_t resets_accepted() const { return resets_accepted_; }
  std::uint64_t resets_refused() const { return resets_refused_; }

 private:
  void latch(LatchCause c);
  SafetyLimits limits_;
  double v_ = 0, w_ = 0;
  StopReason reason_ = StopReason::kNone;
  std::uint64_t stops_ = 0;
  bool latched_ = false, reset_accepted_ = false;
  LatchCause cause_ = LatchCause::kNone;
  std::uint64_t resets_accepted_ = 0, resets_refused_ = 0;
};

}  // namespace cairn::firmware
