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
#include "drivers/modbus/power_link.hpp"

typedef struct _modbus modbus_t;

namespace cairn::modbus {

/// Modbus caps one read of holding/input registers at 125 (MODBUS_MAX_READ_REGISTERS):
/// the four input registers are polled in one read, so they must lie within 125
/// consecutive addresses.
inline constexpr int kMaxReadRegisters = 125;
/// Whether `map` can be polled: slave 1..247, addresses 0..65535, four distinct input
/// registers spanning at most kMaxReadRegisters. False with a clear reason.
bool validate_register_map(const RegisterMap& map, std::string* error);

class PowerBoard final : public PowerLink {
 public:
  /// "tcp:HOST:PORT" or "rtu:DEVICE:BAUD" (8N1). Nullptr and a message on failure: a bad
  /// URI (port 1..65535, a positive baud rate, digits only), an invalid register map
  /// (validate_register_map), or no connection. Never throws for a bad URI.
  static std::unique_ptr<PowerBoard> open(const std::string& uri, const RegisterMap& map, Nanos response_timeout,
                                          std::string* error);
  ~PowerBoard();

  /// Reads all values (two transactions). False with a reason on failure (counted).
  bool poll(PowerState* out, std::string* error) override;
  /// The e-stop fast path: one short transaction reading only the e-stop input.
  /// Returns 1 pressed, 0 released, -1 on failure.
  int estop_pressed() override;
  bool set_motor_power(bool on, std::string* error) override;
  const PowerCounters& counters() const override { return counters_; }

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
