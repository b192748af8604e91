// The web view's map in tiles of kWebTileCells × kWebTileCells cells, each with the version
// in which it last changed: a socket that has seen version v is sent only the tiles newer
// than v (a new socket, or one whose map geometry changed since, all of them), so a large
// map crosses the network once and then only where it changed. Built on the base's main
// loop (WebMapTiles::update) as an immutable snapshot; the server thread only assembles
// each socket's message from it (WebMapSnapshot::message_since).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/occupancy_grid.hpp"

namespace cairn::base {

inline constexpr int kWebTileCells = 64;
inline constexpr std::size_t kWebMaxFrontierCells = 20000;  // beyond: counted, not sent

struct WebMapSnapshot {
  struct Tile {
    std::uint64_t version = 0;                // when its cells last changed
    std::shared_ptr<const std::string> json;  // {"tx", "ty", "png": base64 of its cells, one pixel each}
  };
  std::uint64_t version = 0;           // the newest tile version
  std::uint64_t geometry_version = 0;  // the version that set this geometry: older tiles are void
  std::string head;                    // the geometry and frontier fields, JSON members without braces
  std::vector<Tile> tiles;             // row-major from the lower-left (tx + ty * tiles_x)

  /// {"type": "map", "version", "full", <head>, "tiles": [the tiles newer than `seen`]};
  /// "full" (every tile, the page starts a new image) when `seen` predates the geometry.
  std::string message_since(std::uint64_t seen) const;
};

class WebMapTiles {
 public:
  /// Compares `grid` with the previous one tile by tile and returns the snapshot: changed
  /// tiles get a new version and PNG; a new geometry makes every tile new.
  std::shared_ptr<const WebMapSnapshot> update(const ClassGrid& grid);
  std::uint64_t tiles_encoded() const { return encoded_; }

 private:
  GridGeometry geometry_;
  bool have_ = false;
  std::vector<std::vector<Cell>> cells_;  // per tile, as last encoded
  std::shared_ptr<WebMapSnapshot> last_;
  std::uint64_t version_ = 0, encoded_ = 0;
};

/// The frontier: clear cells with an unknown 4-neighbour (the map's edge is not unknown),
/// as indices j * width + i, at most kWebMaxFrontierCells; *total counts them all.
std::vector<std::size_t> frontier_cells(const ClassGrid& grid, std::size_t* total);

}  // namespace cairn::base
