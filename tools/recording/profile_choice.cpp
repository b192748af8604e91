#include "tools/recording/profile_choice.hpp"

#include "common/config.hpp"

namespace cairn::recording {

dds::DdsProfile choose_profile(const std::string& config_path, int domain) {
  if (config_path.empty()) return dds::loopback_profile(static_cast<std::uint32_t>(domain));
  const ConfigDocument doc = ConfigDocument::load(config_path);
  return dds::profile_from_config(doc.root().optional_section("dds"));
}

}  // namespace cairn::recording
