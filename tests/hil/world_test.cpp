// The HIL world: parsing with clear errors, exact ray casting, the shipped worlds.
#include "hil/world/world.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "hil/world/fleet_bodies.hpp"

namespace cairn::hil {
namespace {

std::string error_of(const std::string& text) {
  try {
    World::parse(text, "w.world");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(World, RayCastingIsExact) {
  const World w = World::parse("box 0 0 10 10\ncircle 5 5 1\npole 8 2 0.05\n", "t");
  // From (2,5) east: the circle's surface at x = 4.
  RayHit h = w.cast({2, 5}, 0.0, 30.0);
  ASSERT_TRUE(h.hit);
  EXPECT_NEAR(h.range, 2.0, 1e-12);
  EXPECT_FALSE(h.reflective);
  // West: the wall at x = 0.
  h = w.cast({2, 5}, std::numbers::pi, 30.0);
  EXPECT_NEAR(h.range, 2.0, 1e-12);
  // Diagonal into the corner (10,10) from (5,9)... the top wall at y = 10.
  h = w.cast({5, 9}, std::numbers::pi / 4, 30.0);
  EXPECT_NEAR(h.range, std::sqrt(2.0), 1e-12);
  // The pole is reflective.
  h = w.cast({2, 2}, 0.0, 30.0);
  EXPECT_NEAR(h.range, 5.95, 1e-12);
  EXPECT_TRUE(h.reflective);
  // Beyond max range: no hit.
  h = w.cast({2, 2}, 0.0, 3.0);
  EXPECT_FALSE(h.hit);
  EXPECT_EQ(h.range, 3.0);
}

TEST(World, RobotsAreReflectiveMovingCircles) {
  World w = World::parse("box 0 0 10 10\n", "t");
  // Facing the ray, turned so it hits 0.2 rad into the first tape run of code 2 (0-60°).
  w.set_robot(2, {6, 5, M_PI - 0.2}, 0.3);
  RayHit h = w.cast({2, 5}, 0.0, 30.0);
  EXPECT_NEAR(h.range, 3.7, 1e-12);
  EXPECT_EQ(h.robot, 2);
  EXPECT_TRUE(h.reflective);
  // Turned 1.2 rad further (hit at 80°: bare), and 2.1 rad further (hit at 132°: the
  // second period's tape).
  w.set_robot(2, {6, 5, M_PI - 1.4}, 0.3);
  EXPECT_FALSE(w.cast({2, 5}, 0.0, 30.0).reflective);
  w.set_robot(2, {6, 5, M_PI - 2.3}, 0.3);
  EXPECT_TRUE(w.cast({2, 5}, 0.0, 30.0).reflective);
  // Robot 9 has no code: tape all round.
  w.set_robot(9, {6, 8, M_PI - 1.4}, 0.3);
  EXPECT_TRUE(w.cast({2, 8}, 0.0, 30.0).reflective);
  w.remove_robot(9);
  w.set_robot(2, {6, 5, M_PI - 0.2}, 0.3);
  EXPECT_FALSE(w.cast({2, 5}, 0.0, 30.0, /*ignore_robot=*/2).reflective);
  w.set_robot(2, {8, 5, M_PI - 0.2}, 0.3);
  EXPECT_NEAR(w.cast({2, 5}, 0.0, 30.0).range, 5.7, 1e-12);
  EXPECT_TRUE(w.collides({7.9, 5.1}, 0.2));
  EXPECT_FALSE(w.collides({3, 3}, 0.2));
  EXPECT_TRUE(w.collides({0.1, 3}, 0.2));
  EXPECT_TRUE(w.poles().empty());
}

// The shared world as a robot's laser sees it on the bench: the other robots, copied from
// the shared bodies into its own copy of the world, are hit with their marker's tape, and
// follow the bodies when they move, without the world growing.
TEST(World, OtherRobotsCopiedFromSharedBodiesAreSeenWithTheirMarkers) {
  const World base = World::parse("box 0 0 20 10\n", "t");
  FleetBodies bodies({{1, {5, 5, 0}, 0.3}, {2, {7, 5, M_PI - 0.2}, 0.3}});
  World sensor_world = base;
  Body others[1];
  auto place_others = [&] {
    const std::size_t n = bodies.snapshot_others(1, others);
    for (std::size_t i = 0; i < n; ++i) sensor_world.set_robot(others[i].id, others[i].pose, others[i].radius);
  };
  place_others();
  const std::size_t circles = sensor_world.circles().size();
  const Vec2 laser{5.2, 5};  // robot 1's laser mount, looking along +x
  RayHit h = sensor_world.cast(laser, 0.0, 30.0);
  EXPECT_NEAR(h.range, 1.5, 1e-12);  // robot 2's surface at x = 6.7
  EXPECT_EQ(h.robot, 2);
  EXPECT_TRUE(h.reflective);  // 0.2 rad into code 2's first tape run
  // Robot 2 turns: the beam meets its bare stretch (80 deg round).
  ASSERT_EQ(bodies.try_move(2, {7, 5, M_PI - 1.4}), 0);
  place_others();
  h = sensor_world.cast(laser, 0.0, 30.0);
  EXPECT_EQ(h.robot, 2);
  EXPECT_FALSE(h.reflective);
  // Robot 2 drives out of the beam: the wall behind it at x = 20.
  ASSERT_EQ(bodies.try_move(2, {7, 8, M_PI - 1.4}), 0);
  place_others();
  h = sensor_world.cast(laser, 0.0, 30.0);
  EXPECT_NEAR(h.range, 14.8, 1e-9);
  EXPECT_EQ(h.robot, 0);
  EXPECT_EQ(sensor_world.circles().size(), circles);
  EXPECT_TRUE(base.circles().empty());  // the world it was copied from is untouched
}

TEST(World, ErrorsNameFileAndLine) {
  EXPECT_NE(error_of("box 0 0 1 1\nwal 0 0 1 1\n").find("w.world:2: unknown keyword 'wal'"), std::string::npos);
  EXPECT_NE(error_of("circle 1 2\n").find("w.world:1: 'circle' expects 3 numbers"), std::string::npos);
  EXPECT_NE(error_of("pole 1 2 -1\n").find("radius must be positive"), std::string::npos);
  EXPECT_NE(error_of("wall 0 0 1 1 extra\n").find("unexpected 'extra'"), std::string::npos);
  EXPECT_NE(error_of("wall 0 0 nan 1\n").find("expects 4 numbers"), std::string::npos);
  // Numbers that used to reach an int conversion unchecked (undefined behaviour) or a grid
  // of 10^13 cells (an allocation that kills the process).
  EXPECT_NE(error_of("start 1e300 1 1 0\n").find("w.world:1: start: the robot id"), std::string::npos);
  EXPECT_NE(error_of("start 1.5 1 1 0\n").find("start: the robot id"), std::string::npos);
  EXPECT_NE(error_of("route 1e12 1 1\n").find("route: expects a robot id"), std::string::npos);
  EXPECT_NE(error_of("bounds 0 0 10 10\nrandom 0.3 1 1e-6\n").find("w.world:2: random: bounds / cell give more"), std::string::npos);
  EXPECT_NE(error_of("random 0.3 -5 1\n").find("random: the seed"), std::string::npos);
  const hil::World ok = hil::World::parse("bounds 0 0 10 10\nstart 65535 1 1 0\nrandom 0.2 7 1\n", "ok.world");
  EXPECT_GT(ok.segments().size(), 0u);
}

TEST(World, ShippedWorldsLoad) {
  const std::filesystem::path dir = std::filesystem::path(CAIRN_SOURCE_DIR_STR) / "hil" / "worlds";
  int n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {  // tuning/ too
    if (e.is_directory()) {
      EXPECT_THROW(World::load(e.path().string()), std::runtime_error) << "a directory is no world";
      continue;
    }
    SCOPED_TRACE(e.path().string());
    const World w = World::load(e.path().string());
    if (e.path().filename() != "hall-bare.world") {  // bare: no pole by design
      EXPECT_GE(w.poles().size(), 5u);
    }
    ASSERT_TRUE(w.start(1).has_value());
    EXPECT_FALSE(w.collides(w.start(1)->translation(), 0.25)) << "robot 1 starts inside an obstacle";
    ++n;
  }
  EXPECT_EQ(n, 9);
  // The random worlds cover their stated fraction of the area with obstacles (4 segments
  // per cell): D 15 % of 1 m cells, E 10 % of 0.5 m cells.
  const World r = World::load((dir / "random15.world").string());
  const double cells = static_cast<double>(r.segments().size() - 4) / 4.0;
  EXPECT_NEAR(cells / 400.0, 0.15, 0.01);
  const World e = World::load((dir / "random_clutter.world").string());
  const double small_cells = static_cast<double>(e.segments().size() - 4) / 4.0;
  EXPECT_NEAR(small_cells / 1600.0, 0.10, 0.01);
}

}  // namespace
}  // namespace cairn::hil

namespace cairn {
namespace {

TEST(World, RoutesAddUpPerRobotAndBadOnesNameTheLine) {
  const hil::World w = hil::World::parse("route 2 1 1 2 2\nroute 1 5 5\nroute 2 3 3\n", "r.world");
  ASSERT_EQ(w.route(2).size(), 3u);
  EXPECT_DOUBLE_EQ(w.route(2)[2].x(), 3.0);
  EXPECT_EQ(w.route(1).size(), 1u);
  EXPECT_TRUE(w.route(3).empty());
  for (const char* bad : {"route 1 1\n", "route 0 1 1\n", "route 1\n", "route 1 1 x\n", "route 1.5 1 1\n"}) {
    try {
      hil::World::parse(std::string("\n") + bad, "r.world");
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("r.world:2:"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace cairn
