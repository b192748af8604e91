// The robot's copy of the base's global map (firmware/global_map.hpp): tiles stored by key
// in storage sized once, classified as the base classifies them, every refusal counted.
#include "firmware/global_map.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#ifdef CAIRN_COUNT_ALLOCS
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn::firmware {
namespace {

constexpr std::size_t kArea = static_cast<std::size_t>(kMapTileSide) * kMapTileSide;
using Cells = std::array<std::uint8_t, kArea>;

TileView tile(int tx, int ty, const Cells& cells, double res = 0.15, double ox = -12.0, double oy = -6.0) {
  const double span = kMapTileSide * res;
  return {static_cast<std::int16_t>(tx), static_cast<std::int16_t>(ty), res, ox + tx * span, oy + ty * span,
          std::span<const std::uint8_t>(cells)};
}

GlobalMapConfig small(std::size_t tiles) {
  GlobalMapConfig c;
  c.max_cells = tiles * kArea;
  return c;
}

TEST(GlobalMap, TilesLandWhereTheirKeysSayAndClassifyAtTheBasesThresholds) {
  GlobalMap map(small(4));
  Cells a;
  a.fill(kMapTileUnknown);
  // The base's p_o 0.65 / p_c 0.196 on the wire's percent: 0..19 clear, 65..100 obstacle.
  const std::array<std::uint8_t, 8> values{0, 19, 20, 64, 65, 100, kMapTileUnknown, 150};
  for (std::size_t k = 0; k < values.size(); ++k) a[k] = values[k];
  Cells b;
  b.fill(100);
  ASSERT_EQ(map.apply(tile(1, 0, a)), GlobalMap::Applied::kStored);
  ASSERT_EQ(map.apply(tile(2, 1, b)), GlobalMap::Applied::kStored);
  ClassGrid g;
  ASSERT_TRUE(map.classify(&g));
  // The bounding box of tiles (1, 0) and (2, 1): 2 × 2 tiles from tile (1, 0)'s corner.
  EXPECT_EQ(g.geometry.width, 2 * kMapTileSide);
  EXPECT_EQ(g.geometry.height, 2 * kMapTileSide);
  EXPECT_DOUBLE_EQ(g.geometry.origin_x, -12.0 + 64 * 0.15);
  EXPECT_DOUBLE_EQ(g.geometry.origin_y, -6.0);
  const std::array<Cell, 8> expect{Cell::kClear,    Cell::kClear,    Cell::kUnknown, Cell::kUnknown,
                                   Cell::kObstacle, Cell::kObstacle, Cell::kUnknown, Cell::kUnknown};
  for (std::size_t k = 0; k < expect.size(); ++k) EXPECT_EQ(g.at(static_cast<int>(k), 0), expect[k]) << "value " << int(values[k]);
  EXPECT_EQ(g.at(64, 64), Cell::kObstacle);   // tile (2, 1)'s first cell
  EXPECT_EQ(g.at(127, 127), Cell::kObstacle);  // and its last
  EXPECT_EQ(g.at(64, 0), Cell::kUnknown);      // tile (2, 0): never received
  EXPECT_EQ(g.at(0, 64), Cell::kUnknown);      // tile (1, 1): never received
  // A world point in tile (2, 1) finds that cell through the geometry.
  int i = 0, j = 0;
  ASSERT_TRUE(g.geometry.cell_of(-12.0 + 2 * 9.6 + 0.01, -6.0 + 9.6 + 0.01, &i, &j));
  EXPECT_EQ(i, 64);
  EXPECT_EQ(j, 64);
}

TEST(GlobalMap, ANewerSampleOfATileReplacesIt) {
  GlobalMap map(small(2));
  Cells a, b;
  a.fill(0);
  b.fill(100);
  map.apply(tile(0, 0, a));
  map.apply(tile(0, 0, b));
  EXPECT_EQ(map.tiles(), 1u);
  EXPECT_EQ(map.counters().applied, 2u);
  ClassGrid g;
  ASSERT_TRUE(map.classify(&g));
  EXPECT_EQ(g.at(10, 10), Cell::kObstacle);
}

TEST(GlobalMap, TilesBeyondTheConfiguredSizeAreCountedNotStored) {
  GlobalMap map(small(2));
  Cells a;
  a.fill(0);
  EXPECT_EQ(map.apply(tile(0, 0, a)), GlobalMap::Applied::kStored);
  EXPECT_EQ(map.apply(tile(1, 0, a)), GlobalMap::Applied::kStored);
  EXPECT_EQ(map.apply(tile(0, 1, a)), GlobalMap::Applied::kOutOfRoom);
  EXPECT_EQ(map.apply(tile(1, 0, a)), GlobalMap::Applied::kStored) << "a stored tile is still updated";
  EXPECT_EQ(map.tiles(), 2u);
  EXPECT_EQ(map.counters().out_of_room, 1u);
  // Two tiles far apart would need a classified map of 36 tiles: refused too.
  GlobalMap sparse(small(4));
  EXPECT_EQ(sparse.apply(tile(0, 0, a)), GlobalMap::Applied::kStored);
  EXPECT_EQ(sparse.apply(tile(5, 5, a)), GlobalMap::Applied::kOutOfRoom);
  EXPECT_EQ(sparse.apply(tile(1, 1, a)), GlobalMap::Applied::kStored);
  // The widest keys a hostile tile can carry: 65 536 x 16 tiles of 4 096 cells is 2^32
  // cells, which a 32-bit size_t wraps to 0 (armhf robots).
  GlobalMap wild(small(4));
  EXPECT_EQ(wild.apply(tile(-32768, 0, a)), GlobalMap::Applied::kStored);
  EXPECT_EQ(wild.apply(tile(32767, 15, a)), GlobalMap::Applied::kOutOfRoom);
  EXPECT_EQ(wild.apply(tile(-32768, 15, a)), GlobalMap::Applied::kOutOfRoom) << "16 tiles tall: more than 4";
  ClassGrid g;
  ASSERT_TRUE(wild.classify(&g));
  EXPECT_EQ(g.geometry.cells(), kArea);
}

TEST(GlobalMap, ATileFromAnotherMapGeometryStartsOver) {
  GlobalMap map(small(4));
  Cells a;
  a.fill(0);
  map.apply(tile(0, 0, a));
  map.apply(tile(1, 0, a));
  EXPECT_EQ(map.apply(tile(0, 0, a, 0.10)), GlobalMap::Applied::kStored);  // the base restarted at 10 cm
  EXPECT_EQ(map.counters().geometry_changes, 1u);
  EXPECT_EQ(map.tiles(), 1u);
  EXPECT_DOUBLE_EQ(map.resolution(), 0.10);
  map.apply(tile(1, 0, a, 0.10, -11.0));  // and then with another origin
  EXPECT_EQ(map.counters().geometry_changes, 2u);
  EXPECT_EQ(map.tiles(), 1u);
}

TEST(GlobalMap, BadTilesAreRefusedAndCounted) {
  GlobalMap map(small(2));
  Cells a;
  a.fill(0);
  EXPECT_EQ(map.apply(tile(0, 0, a, std::nan(""))), GlobalMap::Applied::kInvalid);
  EXPECT_EQ(map.apply(tile(0, 0, a, 0.0)), GlobalMap::Applied::kInvalid);
  EXPECT_EQ(map.apply(tile(0, 0, a, -0.15)), GlobalMap::Applied::kInvalid);
  EXPECT_EQ(map.apply(tile(0, 0, a, 0.15, std::numeric_limits<double>::infinity())), GlobalMap::Applied::kInvalid);
  EXPECT_EQ(map.apply(tile(0, 0, a, 0.15, 1e9)), GlobalMap::Applied::kInvalid);
  TileView short_tile = tile(0, 0, a);
  short_tile.cells = short_tile.cells.first(100);
  EXPECT_EQ(map.apply(short_tile), GlobalMap::Applied::kInvalid);
  EXPECT_EQ(map.counters().invalid, 6u);
  EXPECT_EQ(map.tiles(), 0u);
  ClassGrid g;
  EXPECT_FALSE(map.classify(&g));
}

TEST(GlobalMap, ConfigurationWithoutRoomOrWithCrossedThresholdsIsRefused) {
  GlobalMapConfig c;
  c.max_cells = kArea - 1;
  EXPECT_THROW(GlobalMap{c}, std::invalid_argument);
  c = GlobalMapConfig{};
  c.p_c = 0.7;
  EXPECT_THROW(GlobalMap{c}, std::invalid_argument);
}

#ifdef CAIRN_COUNT_ALLOCS  // the sanitizers' builds cannot link the counting allocator
TEST(GlobalMap, StoringAndClassifyingAllocateNothingOnceReserved) {
  const GlobalMapConfig cfg = small(9);
  GlobalMap map(cfg);
  ClassGrid g;
  g.cells.reserve(cfg.max_cells);
  Cells a;
  a.fill(50);
  testing::start_counting_allocations();
  for (int tx = 0; tx < 3; ++tx) {
    for (int ty = 0; ty < 3; ++ty) map.apply(tile(tx, ty, a));
  }
  const bool ok = map.classify(&g);
  const std::uint64_t allocations = testing::stop_counting_allocations();
  EXPECT_TRUE(ok);
  EXPECT_EQ(map.tiles(), 9u);
  EXPECT_EQ(g.cells.size(), cfg.max_cells);
  EXPECT_EQ(allocations, 0u);
}
#endif

}  // namespace
}  // namespace cairn::firmware
