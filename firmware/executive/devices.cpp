#include "firmware/executive/devices.hpp"

#include <stdexcept>

#include "common/log.hpp"
#include "drivers/modbus/power_board.hpp"

namespace cairn::firmware {

ExecutiveDevices open_devices(const ExecutiveConfig& cfg, Clock& clock, const std::function<bool()>& keep_trying) {
  ExecutiveDevices d;
  std::string err;
  d.can = can::open_port(cfg.can_uri, &err);
  if (!d.can) throw std::runtime_error("drives: cannot open CAN port '" + cfg.can_uri + "': " + err);
  d.power = modbus::PowerBoard::open(cfg.power_uri, cfg.power_map, cfg.power_response_timeout, &err);
  if (!d.power) throw std::runtime_error("power board: cannot open '" + cfg.power_uri + "': " + err);
  // At the configured rate: a fixed-rate link (tcp: to a device server) stays there; on a
  // serial port the driver probes this rate first, then the others.
  for (;;) {
    d.laser = serial::open_stream(cfg.lms_uri, cfg.lms.target_baud, &err);
    if (d.laser) break;
    if (!keep_trying()) throw std::runtime_error("laser: cannot open '" + cfg.lms_uri + "': " + err);
    CAIRN_LOG_WARN("lms", "cannot open {}: {}; retrying", cfg.lms_uri.c_str(), err.c_str());
    clock.sleep_until(clock.now() + cfg.lms.reopen_backoff);
  }
  return d;
}

}  // namespace cairn::firmware
