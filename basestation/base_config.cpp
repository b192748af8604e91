#include "basestation/base_config.hpp"

#include "common/config.hpp"

namespace cairn::base {

BaseConfig load_base_config(const std::string& path) {
  const ConfigDocument doc = ConfigDocument::load(path);
  const ConfigSection root = doc.root();
  BaseConfig c;
  if (const auto b = root.optional_section("base")) c.name = b->string_or("name", "base");
  c.dds = dds::profile_from_config(root.optional_section("dds"));
  if (const auto f = root.optional_section("fleet")) {
    c.stale_after = seconds_to_nanos(f->number_or("stale_after_s", 3.0, {0.1, 3600.0}));
    c.table_period = seconds_to_nanos(f->number_or("table_period_s", 1.0, {0.1, 3600.0}));
  }
  doc.finish();
  return c;
}

}  // namespace cairn::base
