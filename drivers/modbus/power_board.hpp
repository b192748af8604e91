// The robot's power board over Modbus (libmodbus; RTU on a serial line or TCP): battery
// voltage, current, state of charge, board temperature (input registers), the e-stop
// input (discrete input) and the motor-power relay (coil). The register map comes from
// configuration (docs/modbus.md). libmodbus pitfalls respected: an explicit response
// timeout (its default is 0.5 s), one slave id per context, reconnect on a broken link.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "common/clock.hpp"

typedef struct _modbus modbus_t;

namespace cairn::modbus {

struct RegisterMap {
  int slave = 1;
  int voltage = 0, current = 1, soc = 2, temperature = 3;  // input register addresses
  int estop = 0;                                           // discrete input (1 = pressed)
  int motor_relay = 0;                                     // coil (1 = motor power on)
  double voltage_scale = 0.01;     // V per count (u16)
  double current_scale = 0.01;     // A per count (i16, positive = discharging)
  double soc_scale = 0.1;          // % per count (u16)
  double temperature_scale = 0.1;  // °C per count (i16)
};

/// Modbus caps one read of holding/input registers at 125 (MODBUS_MAX_READ_REGISTERS):
/// the four input registers are polled in one read, so they must lie within 125
/// consecutive addresses.
inline constexpr int kMaxReadRegisters = 125;
/// Whether `map` can be polled: slave 1..247, addresses 0..65535, four distinct input
/// registers spanning at most kMaxReadRegisters. False with a clear reason.
bool validate_register_map(const RegisterMap& map, std::string* error);

struct PowerState {
  bool valid = false;
  double voltage = 0, current = 0, soc = 0, temperature = 0;
  bool estop = false;
  Nanos stamp = 0;
};

/// Decodes the four input registers (in map order: voltage, current, soc, temperature)
/// and the e-stop bit; false if a value is outside what a power board can report.
bool decode_power(const std::uint16_t regs[4], bool estop, const RegisterMap& map, PowerState* out);

struct PowerCounters {
  std::uint64_t polls = 0, errors = 0, timeouts = 0, reconnects = 0, invalid = 0;
};

class PowerBoard {
 public:
  /// "tcp:HOST:PORT" or "rtu:DEVICE:BAUD" (8N1). Nullptr and a message on failure: a bad
  /// URI (port 1..65535, a positive baud rate, digits only), an invalid register map
  /// (validate_register_map), or no connection. Never throws for a bad URI.
  static std::unique_ptr<PowerBoard> open(const std::string& uri, const RegisterMap& map, Nanos response_timeout,
                                          std::string* error);
  ~PowerBoard();

  /// Reads all values (two transactions). False with a reason on failure (counted).
  bool poll(PowerState* out, std::string* error);
  /// The e-stop fast path: one short transaction reading only the e-stop input.
  /// Returns 1 pressed, 0 released, -1 on failure.
  int estop_pressed();
  bool set_motor_power(bool on, std::string* error);
  const PowerCounters& counters() const { return counters_; }

 private:
  PowerBoard(modbus_t* ctx, std::string uri, const RegisterMap& map) : ctx_(ctx), uri_(std::move(uri)), map_(map) {}
  void note_failure();
  modbus_t* ctx_;
  std::string uri_;
  RegisterMap map_;
  PowerCounters counters_;
  bool connected_ = true;
};

}  // namespace cairn::modbus
