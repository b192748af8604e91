// The base station's configuration (config/base.toml), read through the strict schema.
#pragma once

#include <string>

#include "common/clock.hpp"
#include "common/dds/profile.hpp"

namespace cairn::base {

struct BaseConfig {
  std::string name = "base";
  dds::DdsProfile dds;
  Nanos stale_after = 3 * kNanosPerSecond;
  Nanos table_period = kNanosPerSecond;
};

BaseConfig load_base_config(const std::string& path);

}  // namespace cairn::base
