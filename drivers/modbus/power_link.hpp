// The robot's power board as the executive uses it: battery values, the e-stop input and
// the motor-power relay. PowerBoard (libmodbus RTU/TCP) is the production link; a caller
// may hand the executive another (a simulation, a test double).
#pragma once

#include <string>

#include "drivers/modbus/power_state.hpp"

namespace cairn::modbus {

class PowerLink {
 public:
  virtual ~PowerLink() = default;
  /// Reads all values. False with a reason on failure (counted).
  virtual bool poll(PowerState* out, std::string* error) = 0;
  /// The e-stop fast path: 1 pressed, 0 released, -1 on failure.
  virtual int estop_pressed() = 0;
  virtual bool set_motor_power(bool on, std::string* error) = 0;
  virtual const PowerCounters& counters() const = 0;
};

}  // namespace cairn::modbus
