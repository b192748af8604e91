#include "basestation/web/web_map_tiles.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "basestation/mapper/export.hpp"
#include "basestation/web/web_state.hpp"

namespace cairn::base {

std::string WebMapSnapshot::message_since(std::uint64_t seen) const {
  const bool full = seen < geometry_version;
  std::string out = "{\"type\":\"map\",\"version\":" + std::to_string(version) + ",\"full\":" + (full ? "true" : "false") + "," +
                    head + ",\"tiles\":[";
  bool first = true;
  for (const Tile& t : tiles) {
    if (!full && t.version <= seen) continue;
    if (!first) out += ',';
    out += *t.json;
    first = false;
  }
  out += "]}";
  return out;
}

std::vector<std::size_t> frontier_cells(const ClassGrid& grid, std::size_t* total) {
  const GridGeometry& g = grid.geometry;
  const auto unknown = [&](int i, int j) { return i >= 0 && j >= 0 && i < g.width && j < g.height && grid.at(i, j) == Cell::kUnknown; };
  std::vector<std::size_t> out;
  *total = 0;
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      if (grid.at(i, j) != Cell::kClear) continue;
      if (!unknown(i - 1, j) && !unknown(i + 1, j) && !unknown(i, j - 1) && !unknown(i, j + 1)) continue;
      if (++*total <= kWebMaxFrontierCells) out.push_back(g.index(i, j));
    }
  }
  return out;
}

std::shared_ptr<const WebMapSnapshot> WebMapTiles::update(const ClassGrid& grid) {
  const GridGeometry& g = grid.geometry;
  const int tiles_x = (g.width + kWebTileCells - 1) / kWebTileCells, tiles_y = (g.height + kWebTileCells - 1) / kWebTileCells;
  const bool new_geometry = !have_ || g.width != geometry_.width || g.height != geometry_.height ||
                            g.resolution != geometry_.resolution || g.origin_x != geometry_.origin_x || g.origin_y != geometry_.origin_y;
  auto snap = std::make_shared<WebMapSnapshot>();
  if (new_geometry) {
    geometry_ = g;
    have_ = true;
    cells_.assign(static_cast<std::size_t>(tiles_x) * static_cast<std::size_t>(tiles_y), {});
    snap->geometry_version = version_ + 1;
    snap->tiles.resize(cells_.size());
  } else {
    snap->geometry_version = last_->geometry_version;
    snap->tiles = last_->tiles;  // shared strings: unchanged tiles are not copied
  }
  bool changed = false;
  mapper::PngOptions png;
  png.pixels_per_cell = 1;  // the page scales it
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      ClassGrid tile;
      tile.geometry.resolution = g.resolution;
      tile.geometry.width = std::min(kWebTileCells, g.width - tx * kWebTileCells);
      tile.geometry.height = std::min(kWebTileCells, g.height - ty * kWebTileCells);
      tile.cells.resize(static_cast<std::size_t>(tile.geometry.width) * static_cast<std::size_t>(tile.geometry.height));
      for (int j = 0; j < tile.geometry.height; ++j)
        for (int i = 0; i < tile.geometry.width; ++i) tile.at(i, j) = grid.at(tx * kWebTileCells + i, ty * kWebTileCells + j);
      const std::size_t k = static_cast<std::size_t>(tx + ty * tiles_x);
      if (!new_geometry && tile.cells == cells_[k]) continue;
      if (!changed) ++version_;
      changed = true;
      cells_[k] = tile.cells;
      snap->tiles[k] = {version_, std::make_shared<const std::string>(
                                      nlohmann::json{{"tx", tx}, {"ty", ty}, {"png", base64(mapper::render_png(tile, {}, {}, png))}}.dump())};
      ++encoded_;
    }
  }
  if (!changed && last_) return last_;  // nothing new: the same snapshot, the same version
  snap->version = version_;
  std::size_t total = 0;
  const std::vector<std::size_t> frontier = frontier_cells(grid, &total);
  const nlohmann::json head{{"origin_x", g.origin_x}, {"origin_y", g.origin_y}, {"resolution", g.resolution},
                            {"width", g.width},       {"height", g.height},     {"tile", kWebTileCells},
                            {"frontier", frontier},   {"frontier_total", total}};
  const std::string h = head.dump();
  snap->head = h.substr(1, h.size() - 2);  // the members, without the braces
  last_ = std::move(snap);
  return last_;
}

}  // namespace cairn::base
