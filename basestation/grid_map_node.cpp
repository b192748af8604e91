#include "basestation/grid_map_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "basestation/mapper/export.hpp"
#include "common/dds/convert.hpp"

namespace cairn::base {

namespace {
constexpr int kTile = kMapTileSide;
}

GridMapNode::GridMapNode(const dds::Participant& pp, const BaseConfig& cfg)
    : cfg_(cfg),
      mapper_(cfg.mapper),
      scan_topic_(pp),
      tile_topic_(pp),
      // Best effort as the robots send them; deep enough for a 20 ms poll at any fleet size.
      scan_reader_(pp, scan_topic_, dds::sensor_qos(16)),
      // One sample per tile instance, kept for late joiners.
      tile_writer_(pp, tile_topic_, dds::latched_qos(1)) {
  const std::size_t tiles = static_cast<std::size_t>(tiles_x()) * static_cast<std::size_t>(tiles_y());
  dirty_.assign(tiles, 0);
  versions_.assign(tiles, 0);
}

GridMapNode::~GridMapNode() = default;

int GridMapNode::tiles_x() const { return (mapper_.geometry().width + kTile - 1) / kTile; }
int GridMapNode::tiles_y() const { return (mapper_.geometry().height + kTile - 1) / kTile; }

void GridMapNode::poll(Nanos now, const Fusion& fusion) {
  frames_.record(fusion);
  scan_reader_.take([&](const cairn_LaserScan& s, const dds_sample_info_t&) {
    ++counters_.scans_taken;
    msg::LaserScan scan;
    if (!dds::from_dds(s, &scan)) {
      ++counters_.scans_malformed;
      return;
    }
    if (!frames_.place(mapper_, scan, fusion)) ++counters_.scans_unplaced;  // refusals are the mapper's counters
  });
  if (now >= next_reframe_) {
    next_reframe_ = now + cfg_.map_reframe_period;
    reframe(fusion);
  }
  if (now >= next_tiles_) {
    next_tiles_ = now + cfg_.map_tile_period;
    publish_dirty();
  }
}

void GridMapNode::reframe(const Fusion& fusion) {
  // Each stored scan at the frame the fusion had for its robot at the scan's time, as far
  // as the fusion knows it now: scans move when that differs by more than rerender_shift_m.
  frames_.record(fusion);
  frames_.rerender(mapper_);
}

void GridMapNode::publish_dirty() {
  if (const auto r = mapper_.take_changed()) {
    for (int ty = r->j0 / kTile; ty <= r->j1 / kTile; ++ty) {
      for (int tx = r->i0 / kTile; tx <= r->i1 / kTile; ++tx) dirty_[static_cast<std::size_t>(tx + ty * tiles_x())] = 1;
    }
  }
  const mapper::GridGeometry& g = mapper_.geometry();
  for (int ty = 0; ty < tiles_y(); ++ty) {
    for (int tx = 0; tx < tiles_x(); ++tx) {
      const auto k = static_cast<std::size_t>(tx + ty * tiles_x());
      if (!dirty_[k]) continue;
      cairn_MapTile& t = *tile_;
      t.robot_id = 0;  // the fused global map
      t.tile_x = static_cast<std::int16_t>(tx);
      t.tile_y = static_cast<std::int16_t>(ty);
      t.version = ++versions_[k];
      t.resolution = static_cast<float>(g.resolution);
      t.origin_x = g.origin_x + tx * kTile * g.resolution;
      t.origin_y = g.origin_y + ty * kTile * g.resolution;
      tile_cells(tx, ty, t.cells);
      if (tile_writer_.write(t)) {
        dirty_[k] = 0;
        ++counters_.tiles_published;
      } else {
        ++counters_.publish_failures;  // stays dirty: sent again next period
      }
    }
  }
}

void GridMapNode::tile_cells(int tx, int ty, std::uint8_t* cells) const {
  const mapper::GridGeometry& g = mapper_.geometry();
  for (int cj = 0; cj < kTile; ++cj) {
    for (int ci = 0; ci < kTile; ++ci) {
      const int i = tx * kTile + ci, j = ty * kTile + cj;
      std::uint8_t v = kMapTileUnknown;
      if (g.contains(i, j) && mapper_.observed(i, j)) v = static_cast<std::uint8_t>(std::lround(100.0 * mapper_.probability(i, j)));
      cells[cj * kTile + ci] = v;
    }
  }
}

std::string GridMapNode::export_to(const std::string& dir, const Fusion& fusion, const std::vector<mapper::MarkedBox>& boxes) {
  reframe(fusion);  // the map as the fusion sees the robots now, not at the last period
  try {
    std::filesystem::create_directories(dir);
    std::vector<msg::Landmark> landmarks;
    fusion.landmarks(&landmarks);
    std::vector<mapper::Trajectory> trajectories;
    for (std::uint16_t id : mapper_.robots()) trajectories.push_back({id, mapper_.trajectory(id)});
    const mapper::ClassGrid grid = mapper_.classified();
    mapper::write_map_server(grid, dir + "/map");
    mapper::PngOptions png;
    png.boxes = boxes;
    mapper::write_png(grid, trajectories, landmarks, dir + "/map.png", png);
    mapper::write_landmarks_json(landmarks, dir + "/landmarks.json");
    std::vector<mapper::TrajectorySample> poses;
    for (std::uint16_t id : mapper_.robots()) {
      for (const mapper::TimedPose& p : mapper_.body_trajectory(id)) poses.push_back({id, p.stamp, p.pose});
    }
    mapper::write_trajectories_csv(poses, dir + "/trajectories.csv");
    ++counters_.exports;
    return "";
  } catch (const std::exception& e) {
    ++counters_.export_failures;
    return e.what();
  }
}

GridMapNode::Area GridMapNode::area() const {
  const ClassGrid g = mapper_.classified();
  const double cell_m2 = g.geometry.resolution * g.geometry.resolution;
  Area a;
  for (const Cell c : g.cells) {
    if (c == Cell::kClear) a.clear_m2 += cell_m2;
    if (c == Cell::kObstacle) a.obstacle_m2 += cell_m2;
  }
  return a;
}

std::string GridMapNode::summary() const {
  const mapper::MapperCounters& m = mapper_.counters();
  char buf[384];
  std::snprintf(buf, sizeof buf,
                "map: scans %llu taken, %llu inserted, %llu unplaced (robot not localised), %llu malformed, %llu refused; "
                "%llu re-rendered, store %zu scans (%llu dropped); tiles %llu published; exports %llu (%llu failed)",
                static_cast<unsigned long long>(counters_.scans_taken), static_cast<unsigned long long>(m.scans_inserted),
                static_cast<unsigned long long>(counters_.scans_unplaced), static_cast<unsigned long long>(counters_.scans_malformed),
                static_cast<unsigned long long>(m.scans_invalid + m.scans_outside), static_cast<unsigned long long>(m.rerendered),
                mapper_.stored_scans(), static_cast<unsigned long long>(m.store_dropped),
                static_cast<unsigned long long>(counters_.tiles_published), static_cast<unsigned long long>(counters_.exports),
                static_cast<unsigned long long>(counters_.export_failures));
  return buf;
}

}  // namespace cairn::base
