// The power board's register map from a configuration section ([power] in robot.toml).
#pragma once

#include "common/config.hpp"
#include "drivers/modbus/power_board.hpp"

namespace cairn::modbus {

/// Reads slave, register addresses and scales; missing keys keep RegisterMap's defaults.
RegisterMap register_map_from_config(const ConfigSection& s);

}  // namespace cairn::modbus
