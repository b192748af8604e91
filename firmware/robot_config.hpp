// The robot's configuration (config/robot.toml), read through the strict schema.
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"
#include "common/dds/profile.hpp"

namespace cairn::firmware {

struct RobotConfig {
  std::uint16_t id = 0;
  std::string name;
  dds::DdsProfile dds;
  Nanos status_period = kNanosPerSecond;
  Nanos liveliness_lease = 1500 * kNanosPerMilli;
};

/// Loads and validates a robot configuration; throws ConfigError naming file, key and expected form.
RobotConfig load_robot_config(const std::string& path);

}  // namespace cairn::firmware
