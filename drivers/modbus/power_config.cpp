#include "drivers/modbus/power_config.hpp"

#include <set>

namespace cairn::modbus {

RegisterMap register_map_from_config(const ConfigSection& s) {
  RegisterMap m;
  auto addr = [&](const char* key, int fallback) { return static_cast<int>(s.integer_or(key, fallback, {0, 65535})); };
  m.slave = static_cast<int>(s.integer_or("slave", m.slave, {1, 247}));
  m.voltage = addr("voltage_register", m.voltage);
  m.current = addr("current_register", m.current);
  m.soc = addr("soc_register", m.soc);
  m.temperature = addr("temperature_register", m.temperature);
  m.estop = addr("estop_input", m.estop);
  m.reset_input = addr("reset_input", m.reset_input);
  m.motor_relay = addr("motor_relay_coil", m.motor_relay);
  m.voltage_scale = s.number_or("voltage_scale", m.voltage_scale, {1e-6, 1e3});
  m.current_scale = s.number_or("current_scale", m.current_scale, {1e-6, 1e3});
  m.soc_scale = s.number_or("soc_scale", m.soc_scale, {1e-6, 1e3});
  m.temperature_scale = s.number_or("temperature_scale", m.temperature_scale, {1e-6, 1e3});
  const std::set<int> regs = {m.voltage, m.current, m.soc, m.temperature};
  if (regs.size() != 4) s.fail("voltage_register", "the four input registers must be distinct");
  std::string why;
  if (!validate_register_map(m, &why)) s.fail("voltage_register", why);
  return m;
}

}  // namespace cairn::modbus
