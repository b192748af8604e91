#include "drivers/canopen/cia402.hpp"

namespace cairn::cia402 {

const char* state_name(State s) {
  switch (s) {
    case State::kNotReadyToSwitchOn: return "not ready to switch on";
    case State::kSwitchOnDisabled: return "switch on disabled";
    case State::kReadyToSwitchOn: return "ready to switch on";
    case State::kSwitchedOn: return "switched on";
    case State::kOperationEnabled: return "operation enabled";
    case State::kQuickStopActive: return "quick stop active";
    case State::kFaultReactionActive: return "fault reaction active";
    case State::kFault: return "fault";
    case State::kUnknown: return "unknown";
  }
  return "?";
}

namespace {
struct Row {
  std::uint16_t mask, value;
  State state;
};
// Order matters only where masks overlap; each statusword matches exactly one row.
constexpr Row kTable[] = {
    {0x4F, 0x00, State::kNotReadyToSwitchOn}, {0x4F, 0x40, State::kSwitchOnDisabled},
    {0x6F, 0x21, State::kReadyToSwitchOn},    {0x6F, 0x23, State::kSwitchedOn},
    {0x6F, 0x27, State::kOperationEnabled},   {0x6F, 0x07, State::kQuickStopActive},
    {0x4F, 0x0F, State::kFaultReactionActive}, {0x4F, 0x08, State::kFault},
};
}  // namespace

State decode(std::uint16_t sw) {
  for (const Row& r : kTable) {
    if ((sw & r.mask) == r.value) return r.state;
  }
  return State::kUnknown;
}

std::uint16_t next_controlword(State current, State target, std::uint16_t last_cw, const Quirks& q) {
  (void)q;
  if (target == State::kSwitchOnDisabled) {
    return current == State::kSwitchOnDisabled || current == State::kNotReadyToSwitchOn ? last_cw & ~cw::kFaultReset
                                                                                      : cw::kDisableVoltage;
  }
  switch (current) {
    case State::kFault:
      // Fault reset acts on the rising edge of bit 7: drop it first if it is already high.
      if (last_cw & cw::kFaultReset) return cw::kDisableVoltage;
      if (q.needs_disable_before_reset && last_cw != cw::kDisableVoltage) return cw::kDisableVoltage;
      return cw::kFaultReset;
    case State::kFaultReactionActive:
    case State::kNotReadyToSwitchOn:
      return cw::kDisableVoltage;  // automatic transitions; nothing to command
    case State::kSwitchOnDisabled:
      return cw::kShutdown;
    case State::kReadyToSwitchOn:
      return cw::kSwitchOn;
    case State::kSwitchedOn:
    case State::kOperationEnabled:
      return cw::kEnableOperation;
    case State::kQuickStopActive:
      return cw::kDisableVoltage;  // leave quick stop through switch-on-disabled
    case State::kUnknown:
      return cw::kDisableVoltage;
  }
  return cw::kDisableVoltage;
}

}  // namespace cairn::cia402
