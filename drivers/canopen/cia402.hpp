// The CiA 402 drive power state machine, table-driven: statusword (mask, value) → state,
// controlword commands, and the next command on the shortest path to a target state,
// with fault reset on the rising edge of bit 7. Device quirks are flags.
#pragma once

#include <cstdint>

namespace cairn::cia402 {

enum class State : std::uint8_t {
  kNotReadyToSwitchOn, kSwitchOnDisabled, kReadyToSwitchOn, kSwitchedOn, kOperationEnabled,
  kQuickStopActive, kFaultReactionActive, kFault, kUnknown
};
const char* state_name(State s);

/// Decodes a statusword (protocols.md §2.6 table).
State decode(std::uint16_t statusword);

namespace cw {
inline constexpr std::uint16_t kShutdown = 0x0006;
inline constexpr std::uint16_t kSwitchOn = 0x0007;
inline constexpr std::uint16_t kEnableOperation = 0x000F;
inline constexpr std::uint16_t kDisableVoltage = 0x0000;
inline constexpr std::uint16_t kQuickStop = 0x0002;
inline constexpr std::uint16_t kFaultReset = 0x0080;
inline constexpr std::uint16_t kHalt = 0x0100;
}  // namespace cw

struct Quirks {
  bool reject_halt = false;          // drive faults or ignores a controlword with bit 8 set
  bool needs_disable_before_reset = true;  // send 0x00 before the 0x80 edge
};

/// The controlword to send now to move from `current` toward `target`
/// (kOperationEnabled or kSwitchOnDisabled). `last_cw` is what was sent last, so a fault
/// reset is a real 0→1 edge on bit 7.
std::uint16_t next_controlword(State current, State target, std::uint16_t last_cw, const Quirks& q = {});

/// Modes of operation (0x6060 / 0x6061).
enum class Mode : std::int8_t { kNone = 0, kProfilePosition = 1, kVelocity = 2, kProfileVelocity = 3, kCyclicSyncVelocity = 9 };

}  // namespace cairn::cia402
