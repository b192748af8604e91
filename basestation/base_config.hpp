// The base station's configuration (config/base.toml), read through the strict schema.
#pragma once

#include <string>
#include <string_view>

#include "basestation/explore/allocator_config.hpp"
#include "basestation/fusion.hpp"
#include "basestation/mapper/mapper.hpp"
#include "basestation/web/web_config.hpp"
#include "common/clock.hpp"
#include "common/dds/profile.hpp"

namespace cairn::base {

struct BaseConfig {
  std::string name = "base";
  dds::DdsProfile dds;
  Nanos stale_after = 3 * kNanosPerSecond;
  Nanos table_period = kNanosPerSecond;

  // [fusion]: cooperative CML over every robot's odometry and features.
  bool fusion_enabled = true;
  std::string state_dir = "cairn-base-state";  // snapshot + write-ahead log (relative to the working directory)
  Nanos snapshot_period = 30 * kNanosPerSecond;
  Nanos correction_period = 200 * kNanosPerMilli;
  Nanos map_period = kNanosPerSecond;
  int history_depth = 512;  // per robot: what a restarted base can still fetch from the robots
  FusionConfig fusion;      // [[robot]] priors, [unknown_robot]

  // [mapper]: the central occupancy grid (docs/mapper.md).
  bool mapper_enabled = true;  // needs [fusion]: scans are placed by its estimates
  mapper::MapperConfig mapper;
  Nanos map_tile_period = kNanosPerSecond;         // changed MapTiles at most this often
  Nanos map_reframe_period = 10 * kNanosPerSecond; // re-render scans whose robot's frame moved
  std::string map_export_dir = "cairn-base-map";   // SIGUSR1 and exit write the map here

  // [explore]: the exploration executive (docs/explore-executive.md). Off by default:
  // robots without bids keep their configured routes.
  bool explore_enabled = false;  // needs [fusion]: bids count only from localised robots
  explore::AllocatorConfig explore;

  // [web]: the live web view (docs/web-view.md). Off by default.
  WebConfig web;
};

BaseConfig load_base_config(const std::string& path);
/// The same from text (tests); `name` stands for the file in messages.
BaseConfig parse_base_config(std::string_view text, const std::string& name);

}  // namespace cairn::base
