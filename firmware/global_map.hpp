// The base's global map as a robot keeps it (for its frontier bids): the MapTile samples it
// receives, copied into storage sized once from configuration (`[map] max_cells`), so
// nothing is allocated while the map grows. A tile is kept by its key (tile_x, tile_y) and
// replaced by every newer sample of it; a tile that does not fit is counted, never silently
// lost. The first tile fixes the map's geometry (resolution, origin); a tile that
// disagrees means the base restarted with another map, and the buffer starts over
// (counted). Cells are classified with the seed's p_o / p_c as the base classifies them,
// to the wire's 1 % steps.
// Pure: plain fields in, no DDS (the bridge converts at the edge).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/occupancy_grid.hpp"

namespace cairn::firmware {

struct GlobalMapConfig {
  std::size_t max_cells = std::size_t{1} << 20;  // 1 Mi cells (1 MiB): 150 m × 150 m at 15 cm
  double p_o = 0.65;                             // obstacle: occupancy >= p_o
  double p_c = 0.196;                            // clear: occupancy <= p_c
};

/// One MapTile's content, as the wire carries it.
struct TileView {
  std::int16_t tile_x = 0, tile_y = 0;
  double resolution = 0;           // m per cell
  double origin_x = 0, origin_y = 0;  // the tile's cell (0, 0) outer corner, global frame
  std::span<const std::uint8_t> cells;  // kMapTileSide², row-major from the lower left
};

struct GlobalMapCounters {
  std::uint64_t applied = 0;           // tile samples stored
  std::uint64_t out_of_room = 0;       // new tiles beyond max_cells (or whose bounding box would be)
  std::uint64_t invalid = 0;           // bad resolution, origin or size
  std::uint64_t geometry_changes = 0;  // a tile from another map geometry: started over
};

class GlobalMap {
 public:
  /// Throws std::invalid_argument when max_cells holds no tile or p_c >= p_o.
  explicit GlobalMap(const GlobalMapConfig& cfg);

  enum class Applied { kStored, kOutOfRoom, kInvalid };
  Applied apply(const TileView& tile);

  std::size_t tiles() const { return used_; }
  std::size_t capacity_tiles() const { return slots_.size(); }
  const GlobalMapCounters& counters() const { return counters_; }
  /// The map's geometry: resolution and the global position of tile (0, 0)'s corner.
  bool has_geometry() const { return used_ > 0; }
  double resolution() const { return resolution_; }

  /// The classified map over the bounding box of the stored tiles, written into `out`
  /// (whose cell storage is reused: reserve max_cells once and this allocates nothing).
  /// Cells inside the box but in no stored tile are unknown. False when no tile is stored.
  bool classify(ClassGrid* out) const;

 private:
  struct Slot {
    std::int16_t tx = 0, ty = 0;
  };
  GlobalMapConfig cfg_;
  std::vector<Slot> slots_;           // first used_ are in use
  std::vector<std::uint8_t> cells_;   // slot k's cells at k·kMapTileSide²
  std::size_t used_ = 0;
  double resolution_ = 0, origin_x_ = 0, origin_y_ = 0;  // of tile (0, 0)
  GlobalMapCounters counters_;
};

}  // namespace cairn::firmware
