// The base station's central mapper on DDS (docs/mapper.md, "In cairn-base"):
//  - every robot's LaserScan (the robots send every Nth scan) is placed at the fusion's
//    estimate of that robot's local frame at the scan's time (MapFrames); a robot the
//    fusion has not localised yet has no place for it (counted, not inserted);
//  - every reframe period the stored scans whose frame at their time the fusion has moved
//    since (a later update spreads over the scans since the one before) are re-rendered;
//  - changed tiles go out as MapTile (reliable, transient-local, one instance per tile,
//    keep-last 1): a robot that starts late receives the whole map, not just what changed;
//  - export() writes the map as map_server's PGM + YAML, a PNG with trajectories and
//    landmark ellipses, and the landmark map as JSON (on SIGUSR1 and at exit in cairn-base).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "basestation/base_config.hpp"
#include "basestation/fusion.hpp"
#include "basestation/map_frames.hpp"
#include "basestation/mapper/export.hpp"
#include "basestation/mapper/mapper.hpp"
#include "common/dds/topics.hpp"
#include "common/occupancy_grid.hpp"

namespace cairn::base {

struct GridMapCounters {
  std::uint64_t scans_taken = 0;      // LaserScan samples read from DDS
  std::uint64_t scans_malformed = 0;  // refused by the conversion (clamped fields)
  std::uint64_t scans_unplaced = 0;   // robot not localised by the fusion yet
  std::uint64_t tiles_published = 0;  // MapTile samples written
  std::uint64_t publish_failures = 0;
  std::uint64_t exports = 0, export_failures = 0;
};

class GridMapNode {
 public:
  /// Throws std::invalid_argument for an invalid [mapper] configuration.
  GridMapNode(const dds::Participant& pp, const BaseConfig& cfg);
  ~GridMapNode();

  /// Takes the LaserScans that arrived, re-renders on schedule and publishes the tiles
  /// that changed on schedule. Never blocks, never throws on data.
  void poll(Nanos now, const Fusion& fusion);
  /// Re-renders what the fusion moved, then writes map.pgm, map.yaml, map.png (with
  /// `boxes` outlined: the unreachable frontiers) and landmarks.json into `dir` (created if
  /// missing). Returns "" on success, else what failed (counted; the base goes on).
  std::string export_to(const std::string& dir, const Fusion& fusion, const std::vector<mapper::MarkedBox>& boxes = {});

  /// Fills `cells` (kMapTileSide²) with tile (tx, ty) of the current grid, as published:
  /// occupancy % for a cell ever observed, kMapTileUnknown otherwise (and outside the grid).
  void tile_cells(int tx, int ty, std::uint8_t* cells) const;
  int tiles_x() const;
  int tiles_y() const;

  const mapper::Mapper& mapper() const { return mapper_; }
  const GridMapCounters& counters() const { return counters_; }
  /// Scans dropped for a robot_id other than their writer's partition's (a robot posing as another).
  std::uint64_t foreign_samples() const { return scan_reader_.foreign_samples(); }
  /// One line for the console.
  std::string summary() const;
  /// The mapped area by class (m²), from the map as classified now: the base's own measure
  /// of what exploration covered (it knows no building outline to divide by).
  struct Area {
    double clear_m2 = 0, obstacle_m2 = 0;
  };
  Area area() const;

 private:
  void reframe(const Fusion& fusion);
  void publish_dirty();

  const BaseConfig& cfg_;
  mapper::Mapper mapper_;
  MapFrames frames_;
  dds::Topic<cairn_LaserScan> scan_topic_;
  dds::Topic<cairn_MapTile> tile_topic_;
  dds::Reader<cairn_LaserScan> scan_reader_;
  dds::Writer<cairn_MapTile> tile_writer_;
  std::vector<std::uint8_t> dirty_;       // per tile, row-major (tx + ty * tiles_x)
  std::vector<std::uint32_t> versions_;   // per tile: the last version published
  std::unique_ptr<cairn_MapTile> tile_ = std::make_unique<cairn_MapTile>();
  Nanos next_tiles_ = 0, next_reframe_ = 0;
  GridMapCounters counters_;
};

}  // namespace cairn::base
