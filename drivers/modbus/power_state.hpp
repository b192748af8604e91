// The power board's register map and the values read through it (plain data; the
// codec and the links share them).
#pragma once

#include <cstdint>

#include "common/clock.hpp"

namespace cairn::modbus {

struct RegisterMap {
  int slave = 1;
  int voltage = 0, current = 1, soc = 2, temperature = 3;  // input register addresses
  int estop = 0;                                           // discrete input (1 = pressed)
  int reset_input = 1;                                     // discrete input (1 = reset button held)
  int motor_relay = 0;                                     // coil (1 = motor power on)
  double voltage_scale = 0.01;     // V per count (u16)
  double current_scale = 0.01;     // A per count (i16, positive = discharging)
  double soc_scale = 0.1;          // % per count (u16)
  double temperature_scale = 0.1;  // °C per count (i16)
};

struct PowerState {
  bool valid = false;
  double voltage = 0, current = 0, soc = 0, temperature = 0;
  bool estop = false;
  Nanos stamp = 0;
};

/// Decodes the four input registers (in map order: voltage, current, soc, temperature)
/// and the e-stop bit; false if a value is outside what a power board can report.
bool decode_power(const std::uint16_t regs[4], bool estop, const RegisterMap& map, PowerState* out);

/// The safety inputs, read together by the e-stop fast path.
struct SafetyInputBits {
  bool estop = false;  // the e-stop input: 1 = pressed
  bool reset = false;  // the board's reset input: 1 = the reset button is held
};

struct PowerCounters {
  std::uint64_t polls = 0, errors = 0, timeouts = 0, reconnects = 0, invalid = 0;
  std::uint64_t input_reads = 0, relay_writes = 0;
};

}  // namespace cairn::modbus
