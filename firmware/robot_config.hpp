// The robot's configuration (config/robot.toml), read through the strict schema.
// Without a [devices] section cairn-robot runs status-only (no hardware: a DDS
// presence for fleet tests); with it, the full executive over the named devices.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "common/dds/profile.hpp"
#include "firmware/executive/executive.hpp"
#include "firmware/executive/path_follower.hpp"
#include "firmware/global_map.hpp"
#include "firmware/nav_monitor.hpp"
#include "firmware/robot_explorer.hpp"

namespace cairn::firmware {

/// A scripted path in the robot's local frame (its start pose is the origin); a
/// TaskAssignment from the base station replaces it.
struct MotionConfig {
  std::vector<Vec2> waypoints;
  FollowerConfig follower;
};

struct RobotConfig {
  std::uint16_t id = 0;
  std::string name;
  dds::DdsProfile dds;
  Nanos status_period = kNanosPerSecond;
  Nanos liveliness_lease = 1500 * kNanosPerMilli;
  bool has_devices = false;    // [devices] present: run the executive
  ExecutiveConfig executive;   // robot_id mirrors `id`
  MotionConfig motion;
  NavMonitorConfig nav_monitor;  // [motion] stuck_after_s, progress_m
  Nanos bridge_period = 2 * kNanosPerMilli;  // how often the DDS side drains the RT queues
  GlobalMapConfig global_map;                // [map]: the base's MapTiles, kept for the bids
  RobotExploreConfig explore;                // [explore]: bids and planning on that map
};

/// Loads and validates a robot configuration; throws ConfigError naming file, key and expected form.
RobotConfig load_robot_config(const std::string& path);
/// The same from TOML text (`name` is used in messages).
RobotConfig parse_robot_config(const std::string& text, const std::string& name);

}  // namespace cairn::firmware
