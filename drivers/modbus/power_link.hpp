// The robot's power board as the executive uses it: battery values, the e-stop input and
// the motor-power relay. PowerBoard (libmodbus RTU/TCP) is the production link; a caller
// may hand the executive another (a simulation, a test double).
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

#include "drivers/modbus/power_state.hpp"

namespace cairn::modbus {

/// Why a power-board transaction failed, without building a string: the I/O thread that
/// reports it allocates nothing. `what` names the transaction (static text), `detail` the
/// cause: libmodbus' text for errno, which is glibc's strerror (static for every errno
/// the C library knows; valid on this thread until its next strerror call otherwise).
struct PowerFault {
  const char* what = "no transaction yet";
  const char* detail = "";
  /// "what: detail" (or "what") into `out`, truncated to its size; for snapshots.
  void format(char* out, std::size_t size) const {
    std::snprintf(out, size, *detail ? "%s: %s" : "%s%s", what, detail);
  }
  std::string text() const { return *detail ? std::string(what) + ": " + detail : std::string(what); }
};

class PowerLink {
 public:
  virtual ~PowerLink() = default;
  /// Reads the battery values (not the e-stop: that is the fast path's). False with a
  /// reason on failure (counted).
  virtual bool poll(PowerState* out, PowerFault* fault) = 0;
  /// The e-stop fast path: the e-stop and reset inputs in one short transaction. False on
  /// failure (counted); every call is bounded by the link's response timeout.
  virtual bool read_safety_inputs(SafetyInputBits* out) = 0;
  /// 1 pressed, 0 released, -1 on failure (read_safety_inputs' e-stop bit).
  int estop_pressed() {
    SafetyInputBits b;
    return read_safety_inputs(&b) ? (b.estop ? 1 : 0) : -1;
  }
  virtual bool set_motor_power(bool on, PowerFault* fault) = 0;
  virtual const PowerCounters& counters() const = 0;
};

}  // namespace cairn::modbus
