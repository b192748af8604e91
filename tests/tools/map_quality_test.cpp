// Map quality on synthetic maps whose answers are known: a perfect map, a map shifted
// by two cells, half a map, a map that claims clear inside furniture; landmarks against
// poles; and the command.
#include "tools/map_quality/map_quality.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "basestation/mapper/export.hpp"
#include "tests/support/subprocess.hpp"

namespace cairn::tools {
namespace {

using mapper::Cell;
using mapper::ClassGrid;
using mapper::GridGeometry;

// Walls on cell centres (res 0.1, cells centred on x.x5): a room 4.9 m x 2.9 m, a 0.5 m
// box of furniture, and a closed cupboard that cannot be reached.
const char* kWorld = R"(bounds 0 0 6 4
box 0.55 0.55 4.9 2.9
box 2.05 1.45 0.5 0.5
box 4.55 2.55 0.6 0.6
start 1 1.0 1.0 0
)";

GridGeometry geometry() { return {0.1, 0.0, 0.0, 60, 40}; }

ClassGrid shifted(const ClassGrid& m, int di, int dj) {
  ClassGrid s = m;
  std::fill(s.cells.begin(), s.cells.end(), Cell::kUnknown);
  for (int j = 0; j < m.geometry.height; ++j)
    for (int i = 0; i < m.geometry.width; ++i)
      if (m.geometry.contains(i + di, j + dj)) s.at(i + di, j + dj) = m.at(i, j);
  return s;
}

TEST(MapQuality, RasterisesWallsAndFloodFillsTheReachableFreeSpace) {
  const hil::World w = hil::World::parse(kWorld, "synthetic");
  const TruthGrid t = rasterise(w, geometry(), {1.0, 1.0});
  EXPECT_EQ(t.at(5, 10), Truth::kWall);   // x = 0.55 wall, on the centre of column 5
  EXPECT_EQ(t.at(4, 10), Truth::kOther);  // outside the room
  EXPECT_EQ(t.at(6, 10), Truth::kFree);
  EXPECT_EQ(t.at(22, 17), Truth::kOther);  // inside the furniture
  EXPECT_EQ(t.at(48, 28), Truth::kOther);  // inside the closed cupboard
  // Room interior 48 x 28 cells, minus the furniture (6x6 incl. its walls) and the cupboard's
  // cells inside the room (column 45..51 x row 25..31 clipped to the interior 6..53 x 6..33).
  EXPECT_EQ(t.at(45, 25), Truth::kWall);
  EXPECT_THROW(rasterise(w, geometry(), {0.55, 1.0}), std::invalid_argument);  // start in a wall
  EXPECT_THROW(rasterise(w, geometry(), {9.0, 1.0}), std::invalid_argument);   // outside the map
}

TEST(MapQuality, PerfectMapScoresPerfectly) {
  const hil::World w = hil::World::parse(kWorld, "synthetic");
  const ClassGrid perfect = truth_as_map(rasterise(w, geometry(), {1.0, 1.0}));
  const MapQuality q = evaluate(perfect, w, {1.0, 1.0});
  EXPECT_DOUBLE_EQ(q.coverage, 1.0);
  EXPECT_DOUBLE_EQ(q.agreement, 1.0);
  EXPECT_EQ(q.false_obstacles, 0u);
  EXPECT_EQ(q.false_free, 0u);
  EXPECT_LE(q.wall_offset_max_m, 0.1 * std::sqrt(0.5) + 1e-9);  // a cell that touches a wall
  EXPECT_LT(q.wall_offset_mean_m, 0.05);
}

TEST(MapQuality, MapShiftedByTwoCellsShowsTwoCellsOfWallOffsetAndLowerAgreement) {
  const hil::World w = hil::World::parse(kWorld, "synthetic");
  const ClassGrid perfect = truth_as_map(rasterise(w, geometry(), {1.0, 1.0}));
  const MapQuality good = evaluate(perfect, w, {1.0, 1.0});
  const MapQuality bad = evaluate(shifted(perfect, 2, 2), w, {1.0, 1.0});
  EXPECT_GE(bad.wall_offset_max_cells(), 2.0 - 1e-9);
  EXPECT_GE(bad.wall_offset_mean_cells(), 1.5);
  EXPECT_LT(bad.agreement, good.agreement - 0.05);
  EXPECT_GT(bad.false_obstacles, 100u);
  EXPECT_GT(bad.false_free, 100u);
  // One cell along x only: the offset of the vertical walls is one cell; horizontal walls stay.
  const MapQuality one = evaluate(shifted(perfect, 1, 0), w, {1.0, 1.0});
  EXPECT_NEAR(one.wall_offset_max_cells(), 1.0, 1e-9);
  EXPECT_GT(one.agreement, bad.agreement);
}

TEST(MapQuality, CoverageCountsOnlyKnownFreeCellsAndFalseFreeInsideFurniture) {
  const hil::World w = hil::World::parse(kWorld, "synthetic");
  const TruthGrid t = rasterise(w, geometry(), {1.0, 1.0});
  ClassGrid half = truth_as_map(t);
  for (int j = 0; j < 40; ++j)
    for (int i = 30; i < 60; ++i) half.at(i, j) = Cell::kUnknown;  // right half never seen
  const MapQuality q = evaluate(half, w, {1.0, 1.0});
  EXPECT_GT(q.coverage, 0.4);
  EXPECT_LT(q.coverage, 0.6);
  EXPECT_DOUBLE_EQ(q.agreement, 1.0);  // what is known is right
  ClassGrid inside = truth_as_map(t);
  inside.at(22, 17) = Cell::kClear;  // inside the furniture
  inside.at(10, 10) = Cell::kObstacle;  // in the open
  const MapQuality f = evaluate(inside, w, {1.0, 1.0});
  EXPECT_EQ(f.false_free, 1u);
  EXPECT_EQ(f.false_obstacles, 1u);
  EXPECT_NEAR(f.wall_offset_max_m, 1.05 - 0.55, 1e-9);  // nearest: the left wall x = 0.55
}

msg::Landmark landmark(std::uint32_t id, double x, double y) {
  msg::Landmark l;
  l.id = id;
  l.x = x;
  l.y = y;
  l.cov = {0.01, 0, 0, 0.01};
  return l;
}

// A 6 m x 4 m room split at x = 3 by a wall with a 0.7 m door (y 1.65..2.35): a disc of
// radius 0.3 m goes through it, one of 0.4 m does not.
const char* kDoorWorld = R"(bounds 0 0 6 4
box 0 0 6 4
wall 3 0 3 1.65
wall 3 2.35 3 4
start 1 1.0 1.0 0
)";

bool drivable_at(const Reference& r, double x, double y) {
  int i = 0, j = 0;
  EXPECT_TRUE(r.truth.geometry.cell_of(x, y, &i, &j));
  return r.drivable[r.truth.geometry.index(i, j)] != 0;
}

TEST(MapQuality, DrivableSpaceIsWhereTheRobotsDiscCanGoThroughTheDoor) {
  const hil::World w = hil::World::parse(kDoorWorld, "door");
  const GridGeometry g{0.1, 0.0, 0.0, 60, 40};
  const Reference fits = make_reference(w, g, {1.0, 1.0}, 0.3);
  const Reference too_wide = make_reference(w, g, {1.0, 1.0}, 0.4);
  EXPECT_TRUE(drivable_at(fits, 1.5, 2.0));
  EXPECT_TRUE(drivable_at(fits, 3.05, 2.0));  // in the door
  EXPECT_TRUE(drivable_at(fits, 4.5, 2.0));   // beyond it
  EXPECT_TRUE(drivable_at(too_wide, 1.5, 2.0));
  EXPECT_FALSE(drivable_at(too_wide, 4.5, 2.0));
  // The room's corner: the disc's centre comes no closer than (0.3, 0.3), so it sweeps the
  // cell centred at (0.15, 0.15) (0.21 m away) but not the one at (0.05, 0.05) (0.35 m).
  EXPECT_TRUE(drivable_at(fits, 0.15, 0.15));
  EXPECT_FALSE(drivable_at(fits, 0.05, 0.05));
  // The free space is the same for both; a map of the near room and the door (x < 3.3 m;
  // the wide disc sweeps up to 3.21 m into it) covers all the wide disc's.
  ClassGrid near_room = truth_as_map(fits.truth);
  for (int j = 0; j < g.height; ++j)
    for (int i = 33; i < g.width; ++i) near_room.at(i, j) = Cell::kUnknown;
  const MapQuality a = evaluate(near_room, fits, w), b = evaluate(near_room, too_wide, w);
  EXPECT_EQ(a.free_cells, b.free_cells);
  EXPECT_DOUBLE_EQ(a.coverage, b.coverage);
  EXPECT_LT(a.coverage, 0.6);
  EXPECT_LT(a.drivable_coverage, 0.6);
  EXPECT_DOUBLE_EQ(b.drivable_coverage, 1.0);
  EXPECT_LT(b.drivable_cells, a.drivable_cells / 2 + 10);
  EXPECT_THROW(make_reference(w, g, {1.0, 1.0}, std::nan("")), std::invalid_argument);
  EXPECT_THROW(make_reference(w, g, {1.0, 1.0}, -0.3), std::invalid_argument);
  EXPECT_THROW(evaluate(near_room, make_reference(w, {0.1, 0.0, 0.0, 50, 40}, {1.0, 1.0}, 0.3), w),
               std::invalid_argument);  // another grid
}

// Two walls at x = 2 (y <= 2) and x = 2.5 (y >= 2.5) split the room; the way between them
// passes between their ends (2, 2) and (2.5, 2.5), 0.71 m apart diagonally: a 0.3 m disc
// goes through (0.35 m from each end at the middle), a 0.36 m one does not. On the map's
// 0.15 m cells the ends' cells alone leave less than 0.6 m: the exact geometry decides.
TEST(MapQuality, DrivableSpaceUsesTheExactGeometryNotTheMapsCells) {
  const hil::World w = hil::World::parse(R"(bounds 0 0 4 4
box 0 0 4 4
wall 2 0 2 2
wall 2.5 2.5 2.5 4
start 1 1.0 3.0 0
)", "diagonal");
  const GridGeometry g{0.15, 0.0, 0.0, 27, 27};
  const Reference fits = make_reference(w, g, {1.0, 3.0}, 0.3);
  const Reference too_wide = make_reference(w, g, {1.0, 3.0}, 0.36);
  EXPECT_TRUE(drivable_at(fits, 3.5, 1.0));
  EXPECT_FALSE(drivable_at(too_wide, 3.5, 1.0));
  EXPECT_TRUE(drivable_at(too_wide, 1.0, 1.0));
}

TEST(MapQuality, LandmarksArePairedOneToOneNearestFirst) {
  const std::vector<Vec2> poles = {{0, 0}, {5, 0}, {10, 0}};
  // (5.2, 0) and (5, 0.3) both lie near pole 2: the nearer one is its pair, the other is
  // spurious; nothing lies within 1 m of pole 3; (20, 20) is nowhere near a pole.
  const std::vector<msg::Landmark> mapped = {landmark(1, 0.1, 0), landmark(2, 5, 0.3), landmark(3, 5.2, 0), landmark(4, 20, 20),
                                             landmark(5, 11.5, 0)};
  const LandmarkQuality q = evaluate_landmarks(mapped, poles);
  EXPECT_EQ(q.poles, 3u);
  EXPECT_EQ(q.landmarks, 5u);
  EXPECT_EQ(q.matched, 2u);
  EXPECT_EQ(q.spurious, 3u);
  EXPECT_EQ(q.missing, 1u);
  EXPECT_NEAR(q.error_mean_m, 0.15, 1e-12);
  EXPECT_NEAR(q.error_rms_m, std::sqrt((0.01 + 0.04) / 2), 1e-12);
  EXPECT_NEAR(q.error_max_m, 0.2, 1e-12);
  const LandmarkQuality none = evaluate_landmarks({}, poles);
  EXPECT_EQ(none.missing, 3u);
  EXPECT_EQ(none.error_max_m, 0.0);
}

TEST(MapQuality, LandmarksJsonRoundTripsAndABadFileIsNamed) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("cairn_landmarks_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::vector<msg::Landmark> in = {landmark(7, 1.25, -3.5), landmark(9, 0, 4)};
  mapper::write_landmarks_json(in, (dir / "l.json").string());
  const std::vector<msg::Landmark> out = mapper::read_landmarks_json((dir / "l.json").string());
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].id, 7u);
  EXPECT_EQ(out[0].x, 1.25);
  EXPECT_EQ(out[0].y, -3.5);
  EXPECT_EQ(out[1].cov, in[1].cov);
  std::ofstream(dir / "bad.json") << R"({"landmarks": [{"id": 1, "x": 0}]})";
  try {
    (void)mapper::read_landmarks_json((dir / "bad.json").string());
    ADD_FAILURE() << "a landmark without y was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)mapper::read_landmarks_json((dir / "missing.json").string()), std::runtime_error);
  fs::remove_all(dir);
}

TEST(MapQuality, CommandReadsAnExportedMapAndPrintsJson) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("cairn_map_quality_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "room.world") << kWorld;
  const hil::World w = hil::World::parse(kWorld, "synthetic");
  mapper::write_map_server(shifted(truth_as_map(rasterise(w, geometry(), {1.0, 1.0})), 2, 2), (dir / "map").string());
  {
    cairn::testing::Subprocess p({CAIRN_MAP_QUALITY_BIN, "--map", (dir / "map.yaml").string(), "--world",
                                  (dir / "room.world").string(), "--json", "--truth", (dir / "truth").string()});
    ASSERT_EQ(p.wait(std::chrono::seconds(30)), 0) << p.output();
    const auto j = nlohmann::json::parse(p.output());
    EXPECT_GE(j.at("wall_offset_max_cells").get<double>(), 2.0 - 1e-6);
    EXPECT_LT(j.at("agreement").get<double>(), 0.95);
    for (const char* k : {"coverage", "agreement", "false_obstacles", "false_free", "wall_offset_mean_m", "wall_offset_max_m"})
      EXPECT_TRUE(j.contains(k)) << k;
  }
  EXPECT_TRUE(fs::exists(dir / "truth.pgm"));
  {
    cairn::testing::Subprocess p({CAIRN_MAP_QUALITY_BIN, "--map", (dir / "map.yaml").string(), "--world",
                                  (dir / "room.world").string(), "--start", "0.55", "1.0"});
    EXPECT_EQ(p.wait(std::chrono::seconds(30)), 2);
    EXPECT_NE(p.output().find("wall cell"), std::string::npos) << p.output();
  }
  {
    cairn::testing::Subprocess p({CAIRN_MAP_QUALITY_BIN, "--map", (dir / "map.yaml").string(), "--world",
                                  (dir / "room.world").string()});
    ASSERT_EQ(p.wait(std::chrono::seconds(30)), 0) << p.output();
    EXPECT_NE(p.output().find("agreement"), std::string::npos);
  }
  // With the base's landmarks, in the room with two poles: one landmark on a pole (5 cm
  // off), one far from both.
  std::ofstream(dir / "poles.world") << kWorld << "pole 3.5 1.0 0.05\npole 1.5 2.5 0.05\n";
  mapper::write_landmarks_json({landmark(1, 3.55, 1.0), landmark(2, 5.0, 3.5)}, (dir / "landmarks.json").string());
  {
    cairn::testing::Subprocess p({CAIRN_MAP_QUALITY_BIN, "--map", (dir / "map.yaml").string(), "--world",
                                  (dir / "poles.world").string(), "--landmarks", (dir / "landmarks.json").string(), "--json"});
    ASSERT_EQ(p.wait(std::chrono::seconds(30)), 0) << p.output();
    const auto j = nlohmann::json::parse(p.output());
    EXPECT_TRUE(j.contains("agreement"));
    EXPECT_EQ(j.at("landmarks").at("poles").get<int>(), 2);
    EXPECT_EQ(j.at("landmarks").at("matched").get<int>(), 1);
    EXPECT_EQ(j.at("landmarks").at("spurious").get<int>(), 1);
    EXPECT_EQ(j.at("landmarks").at("missing").get<int>(), 1);
    EXPECT_NEAR(j.at("landmarks").at("error_max_m").get<double>(), 0.05, 1e-9);
  }
  {
    cairn::testing::Subprocess p({CAIRN_MAP_QUALITY_BIN, "--map", (dir / "map.yaml").string(), "--world",
                                  (dir / "room.world").string(), "--landmarks", (dir / "nope.json").string()});
    EXPECT_EQ(p.wait(std::chrono::seconds(30)), 2);
    EXPECT_NE(p.output().find("nope.json: cannot open"), std::string::npos) << p.output();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cairn::tools
