#include "drivers/modbus/power_board.hpp"

#include <modbus/modbus.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>

namespace cairn::modbus {

bool decode_power(const std::uint16_t regs[4], bool estop, const RegisterMap& m, PowerState* out) {
  PowerState s;
  s.voltage = regs[0] * m.voltage_scale;
  s.current = static_cast<std::int16_t>(regs[1]) * m.current_scale;
  s.soc = regs[2] * m.soc_scale;
  s.temperature = static_cast<std::int16_t>(regs[3]) * m.temperature_scale;
  s.estop = estop;
  // Plausibility: a reading outside these ranges is a wiring, map or device error.
  if (!(s.voltage >= 0 && s.voltage <= 100 && std::abs(s.current) <= 300 && s.soc >= 0 && s.soc <= 100.0001 &&
        s.temperature >= -40 && s.temperature <= 150)) {
    return false;
  }
  s.valid = true;
  *out = s;
  return true;
}

bool validate_register_map(const RegisterMap& m, std::string* error) {
  if (m.slave < 1 || m.slave > 247) {
    *error = "power board register map: slave " + std::to_string(m.slave) + " is not a Modbus unit id (1..247)";
    return false;
  }
  for (int a : {m.voltage, m.current, m.soc, m.temperature, m.estop, m.reset_input, m.motor_relay}) {
    if (a < 0 || a > 65535) {
      *error = "power board register map: address " + std::to_string(a) + " is outside 0..65535";
      return false;
    }
  }
  const int lo = std::min({m.voltage, m.current, m.soc, m.temperature});
  const int hi = std::max({m.voltage, m.current, m.soc, m.temperature});
  if (hi - lo + 1 > kMaxReadRegisters) {
    *error = "power board register map: the input registers span " + std::to_string(lo) + ".." + std::to_string(hi) + " (" +
             std::to_string(hi - lo + 1) + " registers); one Modbus read holds at most " + std::to_string(kMaxReadRegisters) +
             ", so it could never be polled";
    return false;
  }
  if (m.estop == m.reset_input) {
    *error = "power board register map: the e-stop and reset inputs are both discrete input " + std::to_string(m.estop);
    return false;
  }
  if (std::abs(m.estop - m.reset_input) >= kMaxSafetyInputSpan) {
    *error = "power board register map: the e-stop input (" + std::to_string(m.estop) + ") and the reset input (" +
             std::to_string(m.reset_input) + ") must lie within " + std::to_string(kMaxSafetyInputSpan) +
             " bits, so the fast path reads both in one request";
    return false;
  }
  return true;
}

namespace {
// A decimal integer in [lo, hi], the whole string: no exceptions (std::stoi throws on
// "abc" and out-of-range, and accepts "502abc").
std::optional<int> parse_int(std::string_view text, int lo, int hi) {
  int v = 0;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || p != end || v < lo || v > hi) return std::nullopt;
  return v;
}
}  // namespace

std::unique_ptr<PowerBoard> PowerBoard::open(const std::string& uri, const RegisterMap& map, Nanos response_timeout,
                                             std::string* error) {
  if (!validate_register_map(map, error)) return nullptr;
  modbus_t* ctx = nullptr;
  if (uri.rfind("tcp:", 0) == 0) {
    const std::string rest = uri.substr(4);
    const auto c = rest.rfind(':');
    if (c == std::string::npos) {
      *error = "'" + uri + "': expected tcp:HOST:PORT";
      return nullptr;
    }
    const auto port = parse_int(std::string_view(rest).substr(c + 1), 1, 65535);
    if (!port) {
      *error = "'" + uri + "': the TCP port must be a number in 1..65535";
      return nullptr;
    }
    ctx = modbus_new_tcp(rest.substr(0, c).c_str(), *port);
  } else if (uri.rfind("rtu:", 0) == 0) {
    const std::string rest = uri.substr(4);
    const auto c = rest.rfind(':');
    if (c == std::string::npos) {
      *error = "'" + uri + "': expected rtu:DEVICE:BAUD";
      return nullptr;
    }
    const auto baud = parse_int(std::string_view(rest).substr(c + 1), 1, 4'000'000);
    if (!baud) {
      *error = "'" + uri + "': the baud rate must be a positive number (e.g. 115200)";
      return nullptr;
    }
    ctx = modbus_new_rtu(rest.substr(0, c).c_str(), *baud, 'N', 8, 1);
  } else {
    *error = "'" + uri + "': expected tcp:HOST:PORT or rtu:DEVICE:BAUD";
    return nullptr;
  }
  if (!ctx) {
    *error = uri + ": " + modbus_strerror(errno);
    return nullptr;
  }
  modbus_set_slave(ctx, map.slave);
  const auto us = static_cast<std::uint32_t>(response_timeout / kNanosPerMicro);
  modbus_set_response_timeout(ctx, us / 1000000, us % 1000000);  // libmodbus' default is 0.5 s
  modbus_set_byte_timeout(ctx, 0, 50000);
  if (modbus_connect(ctx) != 0) {
    *error = uri + ": cannot connect to the power board: " + modbus_strerror(errno);
    modbus_free(ctx);
    return nullptr;
  }
  return std::unique_ptr<PowerBoard>(new PowerBoard(ctx, uri, map));
}

PowerBoard::~PowerBoard() {
  modbus_close(ctx_);
  modbus_free(ctx_);
}

void PowerBoard::note_failure() {
  ++counters_.errors;
  if (errno == ETIMEDOUT) ++counters_.timeouts;
  if (errno == ECONNRESET || errno == EPIPE || errno == EBADF || errno == ECONNREFUSED) {
    // The link broke: reconnect (TCP server restarted, USB adapter replugged), at most once
    // per kReconnectBackoff; libmodbus bounds the connect itself by the response timeout.
    const Nanos now = MonotonicClock::instance().now();
    if (now < next_reconnect_) return;
    next_reconnect_ = now + kReconnectBackoff;
    modbus_close(ctx_);
    if (modbus_connect(ctx_) == 0) ++counters_.reconnects;
  } else if (uri_.rfind("tcp:", 0) == 0 && errno != EMBXILFUN && errno != EMBXILADD && errno != EMBXILVAL) {
    // A timeout or a bad reply on TCP: the late reply may still be on its way and would be
    // taken as the next request's (a transaction-id mismatch, and so on for every read
    // after). A fresh connection resynchronises at once (connect bounded by the response
    // timeout). An exception reply was a complete answer: nothing to resynchronise.
    modbus_close(ctx_);
    if (modbus_connect(ctx_) == 0) ++counters_.reconnects;
  } else {
    modbus_flush(ctx_);  // resynchronise RTU framing after a bad or late reply
  }
}

bool PowerBoard::poll(PowerState* out, PowerFault* fault) {
  ++counters_.polls;
  std::uint16_t regs[4];
  // One read covers the four registers when they are consecutive (the usual map).
  const int lo = std::min({map_.voltage, map_.current, map_.soc, map_.temperature});
  const int hi = std::max({map_.voltage, map_.current, map_.soc, map_.temperature});
  std::uint16_t block[kMaxReadRegisters];
  // A span over kMaxReadRegisters is refused by validate_register_map(); kept as a guard.
  if (hi - lo >= kMaxReadRegisters || modbus_read_input_registers(ctx_, lo, hi - lo + 1, block) != hi - lo + 1) {
    *fault = {"reading input registers", modbus_strerror(errno)};
    note_failure();
    return false;
  }
  regs[0] = block[map_.voltage - lo];
  regs[1] = block[map_.current - lo];
  regs[2] = block[map_.soc - lo];
  regs[3] = block[map_.temperature - lo];
  if (!decode_power(regs, false, map_, out)) {
    ++counters_.invalid;
    *fault = {"implausible power reading", "check the register map"};
    return false;
  }
  out->stamp = MonotonicClock::instance().now();
  return true;
}

bool PowerBoard::read_safety_inputs(SafetyInputBits* out) {
  ++counters_.input_reads;
  const int lo = std::min(map_.estop, map_.reset_input);
  const int n = std::abs(map_.estop - map_.reset_input) + 1;  // <= kMaxSafetyInputSpan (validated)
  std::uint8_t bits[kMaxSafetyInputSpan] = {};
  if (n > kMaxSafetyInputSpan || modbus_read_input_bits(ctx_, lo, n, bits) != n) {
    note_failure();
    return false;
  }
  out->estop = bits[map_.estop - lo] != 0;
  out->reset = bits[map_.reset_input - lo] != 0;
  return true;
}

bool PowerBoard::set_motor_power(bool on, PowerFault* fault) {
  ++counters_.relay_writes;
  if (modbus_write_bit(ctx_, map_.motor_relay, on ? 1 : 0) != 1) {
    *fault = {"switching the motor relay", modbus_strerror(errno)};
    note_failure();
    return false;
  }
  return true;
}

}  // namespace cairn::modbus
