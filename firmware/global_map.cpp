#include "firmware/global_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace cairn::firmware {

namespace {
constexpr std::size_t kTileArea = static_cast<std::size_t>(kMapTileSide) * kMapTileSide;
}

GlobalMap::GlobalMap(const GlobalMapConfig& cfg) : cfg_(cfg) {
  if (cfg.max_cells < kTileArea) {
    throw std::invalid_argument("map.max_cells must hold at least one tile (" + std::to_string(kTileArea) + " cells)");
  }
  if (!(cfg.p_c >= 0 && cfg.p_c < cfg.p_o && cfg.p_o <= 1)) throw std::invalid_argument("map: need 0 <= p_c < p_o <= 1");
  slots_.resize(cfg.max_cells / kTileArea);
  cells_.resize(slots_.size() * kTileArea);
}

GlobalMap::Applied GlobalMap::apply(const TileView& t) {
  const double res = t.resolution;
  const bool finite = std::isfinite(res) && std::isfinite(t.origin_x) && std::isfinite(t.origin_y);
  if (!finite || res <= 0 || res > 100 || t.cells.size() != kTileArea || std::abs(t.origin_x) > 1e7 ||
      std::abs(t.origin_y) > 1e7) {
    ++counters_.invalid;
    return Applied::kInvalid;
  }
  // Where this tile says tile (0, 0) lies.
  const double span = kMapTileSide * res;
  const double ox = t.origin_x - t.tile_x * span, oy = t.origin_y - t.tile_y * span;
  if (used_ > 0) {
    const double tol = 1e-3 * resolution_;
    if (std::abs(res - resolution_) > 1e-6 * resolution_ || std::abs(ox - origin_x_) > tol || std::abs(oy - origin_y_) > tol) {
      ++counters_.geometry_changes;
      used_ = 0;  // another map: start over
    }
  }
  if (used_ == 0) {
    resolution_ = res;
    origin_x_ = ox;
    origin_y_ = oy;
  }
  std::size_t k = 0;
  while (k < used_ && !(slots_[k].tx == t.tile_x && slots_[k].ty == t.tile_y)) ++k;
  if (k == used_) {
    // The classified map spans the tiles' bounding box: it too must fit in max_cells.
    int tx0 = t.tile_x, tx1 = t.tile_x, ty0 = t.tile_y, ty1 = t.tile_y;
    for (std::size_t m = 0; m < used_; ++m) {
      tx0 = std::min<int>(tx0, slots_[m].tx);
      tx1 = std::max<int>(tx1, slots_[m].tx);
      ty0 = std::min<int>(ty0, slots_[m].ty);
      ty1 = std::max<int>(ty1, slots_[m].ty);
    }
    // Per axis first, then in 64 bits: on a 32-bit robot a product of two wild tile keys
    // (-32768 and 32767) wraps to a small number.
    const auto max_tiles = static_cast<std::uint64_t>(cfg_.max_cells / kTileArea);
    const auto bx = static_cast<std::uint64_t>(tx1 - tx0 + 1), by = static_cast<std::uint64_t>(ty1 - ty0 + 1);
    if (used_ == slots_.size() || bx > max_tiles || by > max_tiles || bx * by > max_tiles) {
      ++counters_.out_of_room;
      return Applied::kOutOfRoom;
    }
    slots_[used_++] = {t.tile_x, t.tile_y};
  }
  std::memcpy(cells_.data() + k * kTileArea, t.cells.data(), kTileArea);
  ++counters_.applied;
  return Applied::kStored;
}

bool GlobalMap::classify(ClassGrid* out) const {
  if (used_ == 0) return false;
  int tx0 = slots_[0].tx, tx1 = tx0, ty0 = slots_[0].ty, ty1 = ty0;
  for (std::size_t k = 1; k < used_; ++k) {
    tx0 = std::min<int>(tx0, slots_[k].tx);
    tx1 = std::max<int>(tx1, slots_[k].tx);
    ty0 = std::min<int>(ty0, slots_[k].ty);
    ty1 = std::max<int>(ty1, slots_[k].ty);
  }
  GridGeometry& g = out->geometry;
  g.resolution = resolution_;
  g.origin_x = origin_x_ + tx0 * kMapTileSide * resolution_;
  g.origin_y = origin_y_ + ty0 * kMapTileSide * resolution_;
  g.width = (tx1 - tx0 + 1) * kMapTileSide;
  g.height = (ty1 - ty0 + 1) * kMapTileSide;
  out->cells.assign(g.cells(), Cell::kUnknown);
  const auto o_pct = static_cast<int>(std::ceil(100.0 * cfg_.p_o - 1e-9));
  const auto c_pct = static_cast<int>(std::floor(100.0 * cfg_.p_c + 1e-9));
  for (std::size_t k = 0; k < used_; ++k) {
    const std::uint8_t* src = cells_.data() + k * kTileArea;
    const int i0 = (slots_[k].tx - tx0) * kMapTileSide, j0 = (slots_[k].ty - ty0) * kMapTileSide;
    for (int cj = 0; cj < kMapTileSide; ++cj) {
      for (int ci = 0; ci < kMapTileSide; ++ci) {
        const std::uint8_t v = src[cj * kMapTileSide + ci];
        Cell c = Cell::kUnknown;
        if (v != kMapTileUnknown && v <= 100) c = v >= o_pct ? Cell::kObstacle : (v <= c_pct ? Cell::kClear : Cell::kUnknown);
        out->at(i0 + ci, j0 + cj) = c;
      }
    }
  }
  return true;
}

}  // namespace cairn::firmware
