// Which DDS profile a recording tool joins: a Cairn configuration's [dds] section (the
// base's or a robot's, so the tool sees what they see), else the loopback profile.
#pragma once

#include <string>

#include "common/dds/profile.hpp"

namespace cairn::recording {

/// config_path "" = no file: the loopback profile on `domain` (CYCLONEDDS_URI is used only
/// through a configuration that asks for profile "env").
dds::DdsProfile choose_profile(const std::string& config_path, int domain);

}  // namespace cairn::recording
