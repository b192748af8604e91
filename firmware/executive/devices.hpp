// Opens the executive's devices from the URIs of its configuration: the laser's byte
// stream (serial:, tty:, tcp:), the CAN port (socketcan:, userspace bus) and the power
// board (Modbus rtu:, tcp:). cairn-robot's main calls this; tests and cairn-sim build
// their devices themselves.
#pragma once

#include <functional>

#include "firmware/executive/executive.hpp"

namespace cairn::firmware {

/// Opens the CAN port and the power board (std::runtime_error naming the device, its URI
/// and the reason when one cannot be opened) and the laser's link, retried every
/// `cfg.lms.reopen_backoff` while `keep_trying()` says so (a device server may come up
/// after the robot); std::runtime_error when it gives up.
ExecutiveDevices open_devices(const ExecutiveConfig& cfg, Clock& clock, const std::function<bool()>& keep_trying);

}  // namespace cairn::firmware
