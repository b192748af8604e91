// Every configuration shipped in config/ loads through its program's schema.
#include <gtest/gtest.h>

#include <filesystem>

#include "basestation/base_config.hpp"
#include "common/config.hpp"
#include "firmware/robot_config.hpp"

namespace cairn {
namespace {

std::filesystem::path config_dir() { return std::filesystem::path(CAIRN_SOURCE_DIR_STR) / "config"; }

TEST(ShippedConfig, EveryTomlFileLoadsWithItsSchema) {
  int loaded = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(config_dir())) {
    if (entry.path().extension() != ".toml") continue;
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(entry.path().string());
    if (name.rfind("robot", 0) == 0) {
      EXPECT_NO_THROW(firmware::load_robot_config(entry.path().string()));
    } else if (name.rfind("base", 0) == 0) {
      EXPECT_NO_THROW(base::load_base_config(entry.path().string()));
    } else {
      ADD_FAILURE() << "no schema known for shipped config " << name << " (name it robot*.toml or base*.toml)";
    }
    ++loaded;
  }
  EXPECT_GE(loaded, 2);
}

TEST(ShippedConfig, ShippedProfilesAreLoopback) {
  const auto robot = firmware::load_robot_config((config_dir() / "robot.toml").string());
  EXPECT_TRUE(robot.dds.loopback_only);
  const auto base = base::load_base_config((config_dir() / "base.toml").string());
  EXPECT_TRUE(base.dds.loopback_only);
}

}  // namespace
}  // namespace cairn
