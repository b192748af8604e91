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
/// The e-stop and reset inputs are read in one request: at most this many bits apart.
inline constexpr int kMaxSafetyInputSpan = 16;
/// A broken link is reconnected at most this often (each attempt is bounded by the
/// response timeout: libmodbus' TCP connect waits at most that long).
inline constexpr Nanos kReconnectBackoff = 100 * kNanosPerMilli;
/// Whether `map` can be polled: slave 1..247, addresses 0..65535, four distinct input
/// registers spanning at most kMaxReadRegisters, distinct e-stop and reset inputs at most
/// kMaxSafetyInputSpan bits apart. False with a clear reason.
bool validate_register_map(const RegisterMap& map, std::string* error);

class PowerBoard final : public PowerLink {
 public:
  /// "tcp:HOST:PORT" or "rtu:DEVICE:BAUD" (8N1). Nullptr and a message on failure: a bad
  /// URI (port 1..65535, a positive baud rate, digits only), an invalid register map
  /// (validate_register_map), or no connection. Never throws for a bad URI.
  static std::unique_ptr<PowerBoard> open(const std::string& uri, const RegisterMap& map, Nanos response_timeout,
                                          std::string* error);
  ~PowerBoard();

  /// Reads the battery values: one transaction (the four input registers). The e-stop is
  /// not read here (read_safety_inputs() is the fast path). False with a reason on failure.
  bool poll(PowerState* out, PowerFault* fault) override;
  /// The e-stop fast path: one short transaction reading the e-stop and reset discrete
  /// inputs (one read when they lie within kMaxSafetyInputSpan bits, which
  /// validate_register_map() requires). False on failure (counted; a broken link is
  /// reconnected at most once per reconnect_backoff, each attempt bounded by the
  /// response timeout).
  bool read_safety_inputs(SafetyInputBits* out) override;
  /// Writes the motor-power relay coil (one transaction).
  bool set_motor_power(bool on, PowerFault* fault) override;
  const PowerCounters& counters() const override { return counters_; }

 private:
  PowerBoard(modbus_t* ctx, std::string uri, const RegisterMap& map) : ctx_(ctx), uri_(std::move(uri)), map_(map) {}
  void note_failure();
  modbus_t* ctx_;
  std::string uri_;
  RegisterMap map_;
  PowerCounters counters_;
  bool connected_ = true;
  Nanos next_reconnect_ = 0;
};

}  // namespace cairn::modbus
