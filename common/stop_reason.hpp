// Why a robot is stopped: RobotStatus.stop_reason on the wire. Written once here, for
// the robot that sets it (firmware/executive/safety.hpp) and the base that reads it
// (cairn-base --reset-estop); docs/firmware.md describes each.
#pragma once

#include <cstdint>

namespace cairn {

enum class StopReason : std::uint8_t {
  kNone = 0,
  kEstop = 1,            // the power board's e-stop input
  kDrivesNotReady = 2,   // a drive is not operation enabled (booting, fault, heartbeat lost)
  kLinkLost = 3,         // no PoseCorrection / TaskAssignment within the link timeout
  kLaserLost = 4,        // no scan within the laser timeout
  kCommandStale = 5,     // the velocity source went silent
  kPowerLost = 6,        // the power board (its e-stop input) does not answer
  kFeedbackStale = 7,    // no fresh wheel feedback (TPDO) from an enabled drive, or the CAN thread stalled
  kResetRequired = 8,    // latched (e-stop released, input or CAN thread back): waiting for a reset
  kProtectiveField = 9,  // the laser sees something on the path closer than the robot can stop in (not latched)
};

/// The highest code this build knows: a peer reporting a higher one is newer than us.
inline constexpr StopReason kLastStopReason = StopReason::kProtectiveField;

constexpr const char* stop_reason_text(StopReason r) {
  switch (r) {
    case StopReason::kNone: return "none";
    case StopReason::kEstop: return "e-stop pressed";
    case StopReason::kDrivesNotReady: return "drives not operation enabled";
    case StopReason::kLinkLost: return "base-station link lost";
    case StopReason::kLaserLost: return "laser silent";
    case StopReason::kCommandStale: return "no velocity command";
    case StopReason::kPowerLost: return "power board silent";
    case StopReason::kFeedbackStale: return "wheel feedback stale";
    case StopReason::kResetRequired: return "e-stop latched: reset required";
    case StopReason::kProtectiveField: return "protective field: path blocked";
  }
  return "unknown";
}

/// The supervisor checks the latch after these three (firmware/executive/safety.cpp), so
/// while one of them holds, the status cannot tell whether the latch is also set; and a
/// reset is refused while any holds (e-stop pressed, its input stale, the CAN thread
/// stalled). Every other reason means the latch is clear.
constexpr bool stop_reason_masks_latch(StopReason r) {
  return r == StopReason::kEstop || r == StopReason::kPowerLost || r == StopReason::kFeedbackStale;
}

}  // namespace cairn
