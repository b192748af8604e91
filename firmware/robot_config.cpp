#include "firmware/robot_config.hpp"

#include "common/config.hpp"

namespace cairn::firmware {

RobotConfig load_robot_config(const std::string& path) {
  const ConfigDocument doc = ConfigDocument::load(path);
  const ConfigSection root = doc.root();
  RobotConfig c;
  const ConfigSection robot = root.section("robot");
  c.id = static_cast<std::uint16_t>(robot.integer("id", {1, 250}));
  c.name = robot.string_or("name", "robot-" + std::to_string(c.id));
  c.dds = dds::profile_from_config(root.optional_section("dds"));
  if (const auto status = root.optional_section("status")) {
    c.status_period = seconds_to_nanos(status->number_or("period_s", 1.0, {0.01, 60.0}));
    c.liveliness_lease = seconds_to_nanos(status->number_or("liveliness_lease_s", 1.5, {0.1, 60.0}));
  }
  doc.finish();
  return c;
}

}  // namespace cairn::firmware
