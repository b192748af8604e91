// The base's Foxglove channels, built on the main loop from its own state (the map, the
// fleet, the fusion, the web view's state JSON) into immutable FoxgloveSnapshots for the
// web server. All in frame "map" (the global frame; x east, y north, metres):
//   1 /map                  foxglove.Grid         the occupancy map, cells coloured as the web map's
//   2 /cairn/scene          foxglove.SceneUpdate  robots (disc, heading arrow, 3σ ellipse, name), landmarks (3σ ellipses)
//   3 /cairn/robots/poses   foxglove.PosesInFrame every localised robot's pose, ascending id
//   4 /cairn/state          cairn.WebState        the web view's state JSON as it is
//   1000 + id  /cairn/robots/<id>/pose  foxglove.PoseInFrame  one per localised robot
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "basestation/fleet.hpp"
#include "basestation/fusion.hpp"
#include "basestation/web/foxglove_snapshot.hpp"
#include "common/occupancy_grid.hpp"

namespace cairn::base {

inline constexpr std::uint32_t kFoxgloveMapChannel = 1, kFoxgloveSceneChannel = 2, kFoxglovePosesChannel = 3,
                               kFoxgloveStateChannel = 4, kFoxgloveRobotPoseChannelBase = 1000;
/// A bigger map is not sent to Foxglove (4 bytes a cell, base64: ~5.6 MB at this size).
inline constexpr std::size_t kFoxgloveMaxGridCells = 1024 * 1024;
inline constexpr std::size_t kFoxgloveMaxLandmarks = 1000;  // as the web view

/// foxglove.Grid of a classified map, RGBA cells (obstacle black, clear white, unknown grey,
/// half transparent), row 0 at the map's lower edge. Empty text if the map is empty or too big.
std::string foxglove_grid_json(const ClassGrid& grid, std::uint64_t stamp_ns);
/// foxglove.SceneUpdate: deletes every earlier entity, then the robots and landmarks now.
std::string foxglove_scene_json(const Fleet& fleet, const Fusion* fusion, std::uint64_t stamp_ns);

class FoxgloveChannels {
 public:
  /// A new map for /map (kept for the snapshots that follow).
  void set_map(const ClassGrid& grid, std::uint64_t stamp_ns);
  /// Every channel with its latest message: /map as last set, the rest built now.
  std::shared_ptr<const FoxgloveSnapshot> snapshot(const Fleet& fleet, const Fusion* fusion,
                                                   std::shared_ptr<const std::string> state_json, std::uint64_t stamp_ns);
  std::uint64_t maps_too_big() const { return maps_too_big_; }

 private:
  std::uint64_t next_version_ = 1;
  FoxgloveChannel map_;
  std::uint64_t maps_too_big_ = 0;
};

}  // namespace cairn::base
