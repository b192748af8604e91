// A robot's exploration over its copy of the global map (firmware/robot_explorer.hpp):
// bids every period from its global pose, plans the base's target around walls, replans
// every period, stands when it cannot plan, and cuts a path to what a task holds.
#include "firmware/robot_explorer.hpp"
#include "firmware/explore/block_marks.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

namespace cairn::firmware {
namespace {

constexpr double kRes = 0.15;
constexpr int kSide = kMapTileSide;

// Fills a GlobalMap of tiles_x × tiles_y tiles (origin 0, 0) with the occupancy `at(x, y)`
// gives for each cell centre (0 clear, 100 obstacle, kMapTileUnknown).
void fill(GlobalMap* map, int tiles_x, int tiles_y, const std::function<std::uint8_t(double, double)>& at) {
  std::array<std::uint8_t, kSide * kSide> cells{};
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      for (int cj = 0; cj < kSide; ++cj) {
        for (int ci = 0; ci < kSide; ++ci) {
          cells[static_cast<std::size_t>(cj * kSide + ci)] = at((tx * kSide + ci + 0.5) * kRes, (ty * kSide + cj + 0.5) * kRes);
        }
      }
      const TileView v{static_cast<std::int16_t>(tx), static_cast<std::int16_t>(ty), kRes, tx * kSide * kRes, ty * kSide * kRes,
                       std::span<const std::uint8_t>(cells)};
      ASSERT_EQ(map->apply(v), GlobalMap::Applied::kStored);
    }
  }
}

// A 6 × 6 m room (x, y in [1, 7]) with 0.3 m walls and a 1.2 m door in its east wall at
// y in [3.4, 4.6]; beyond the east wall nothing is known yet.
std::uint8_t room(double x, double y) {
  if (x > 7.3) return kMapTileUnknown;
  if (x < 0.7 || y < 0.7 || y > 7.3) return 100;
  const bool wall = x < 1.0 || y < 1.0 || y > 7.0 || x > 7.0;
  const bool door = x > 7.0 && y > 3.4 && y < 4.6;
  return wall && !door ? 100 : 0;
}

GlobalMapConfig map_cfg(std::size_t tiles) {
  GlobalMapConfig c;
  c.max_cells = tiles * kSide * kSide;
  return c;
}

RobotExploreConfig explore_cfg() {
  RobotExploreConfig c;
  c.enabled = true;
  c.bid_period = 2 * kNanosPerSecond;
  c.bidder.sensor_range_m = 4.0;
  return c;
}

msg::TaskAssignment task(std::uint32_t id, msg::TaskKind kind, double x, double y) {
  msg::TaskAssignment t{};
  t.robot_id = 5;
  t.task_id = id;
  t.kind = kind;
  t.target_x = x;
  t.target_y = y;
  return t;
}

TEST(RobotExplorer, BidsTheDoorEveryPeriodFromItsGlobalPose) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, room);
  RobotExplorer ex(explore_cfg(), 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{3, 3, 0};
  auto s = ex.step(map, at, 0, &bid, &route);
  ASSERT_TRUE(s.bid);
  EXPECT_FALSE(s.route);
  EXPECT_EQ(bid.robot_id, 5);
  EXPECT_EQ(bid.seq, 1u);
  ASSERT_GE(bid.n_items, 1);
  for (std::size_t k = 0; k < bid.n_items; ++k) {  // the only frontier: the door's cells
    EXPECT_NEAR(bid.items[k].x, 7.15, 0.2) << k;
    EXPECT_GT(bid.items[k].y, 3.3) << k;
    EXPECT_LT(bid.items[k].y, 4.7) << k;
    EXPECT_GT(bid.items[k].gain, 100) << "the unknown east beyond the door";
    EXPECT_GT(bid.items[k].cost, 4.0);
  }
  EXPECT_FALSE(ex.step(map, at, kNanosPerSecond, &bid, &route).bid) << "not before the period";
  s = ex.step(map, at, 2 * kNanosPerSecond, &bid, &route);
  EXPECT_TRUE(s.bid);
  EXPECT_EQ(bid.seq, 2u);
  EXPECT_EQ(ex.counters().bids, 2u);
}

// The room with a partition from the south wall up to y = 5.5 at x = 4: from the room's
// west half the door is reached only through the 1.5 m gap north of it.
std::uint8_t partitioned(double x, double y) {
  if (x > 3.85 && x < 4.15 && y < 5.5 && y > 0.7) return 100;
  return room(x, y);
}

TEST(RobotExplorer, ATaskIsPlannedAroundTheWallsAtOnceAndReplannedEachPeriod) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, partitioned);
  RobotExplorer ex(explore_cfg(), 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{2.5, 2.5, 0};  // west of the partition: the straight line to the door crosses it
  (void)ex.step(map, at, 0, &bid, &route);
  ex.on_task(task(11, msg::TaskKind::kExplore, 7.15, 4.0));
  auto s = ex.step(map, at, 100 * kNanosPerMilli, &bid, &route);  // a new task is planned at once
  ASSERT_TRUE(s.route);
  EXPECT_FALSE(s.bid);
  EXPECT_EQ(route.kind, msg::TaskKind::kExplore);
  EXPECT_EQ(route.task_id, 11u);
  ASSERT_GE(route.n_path, 5);
  EXPECT_NEAR(route.target_x, 7.15, 0.2);
  EXPECT_NEAR(route.target_y, 4.0, 0.2);
  Vec2 prev(at.x, at.y);
  bool through_gap = false;
  for (std::size_t i = 0; i < route.n_path; ++i) {
    const Vec2 p(route.path_xy[2 * i], route.path_xy[2 * i + 1]);
    EXPECT_EQ(partitioned(p.x(), p.y()), 0) << "waypoint " << i << " at " << p.transpose() << " is not clear";
    EXPECT_LT((p - prev).norm(), 0.5) << "waypoints about 0.3 m apart";
    through_gap = through_gap || (std::abs(p.x() - 4.0) < 0.5 && p.y() > 5.5);
    prev = p;
  }
  EXPECT_TRUE(through_gap) << "the path must go round the partition's north end";
  EXPECT_FALSE(ex.step(map, at, kNanosPerSecond, &bid, &route).route) << "no replan before the period";
  // Next period, from where the robot is now (east of the partition): straight to the door.
  s = ex.step(map, Pose2{6, 2.5, 0}, 2 * kNanosPerSecond, &bid, &route);
  ASSERT_TRUE(s.route);
  EXPECT_TRUE(s.bid);
  ASSERT_GE(route.n_path, 1);
  EXPECT_LT((Vec2(route.path_xy[0], route.path_xy[1]) - Vec2(6, 2.5)).norm(), 0.5) << "the replan starts where the robot is";
  EXPECT_EQ(ex.counters().plans, 2u);
  // The base says idle: nothing more to plan.
  ex.on_task(task(12, msg::TaskKind::kIdle, 0, 0));
  EXPECT_FALSE(ex.step(map, at, 4 * kNanosPerSecond, &bid, &route).route);
  // A task that carries its own path is the base's to give: followed as given, not replanned.
  msg::TaskAssignment with_path = task(13, msg::TaskKind::kGoto, 6, 6);
  with_path.n_path = 1;
  with_path.path_xy[0] = 5;
  with_path.path_xy[1] = 6;
  ex.on_task(with_path);
  EXPECT_FALSE(ex.step(map, at, 6 * kNanosPerSecond, &bid, &route).route);
}

// The room split by a wall at x = 4 with two 1.2 m gaps, south (y 1.5..2.7) and north
// (y 5.3..6.5).
std::uint8_t two_gaps(double x, double y) {
  const bool gap = (y > 1.5 && y < 2.7) || (y > 5.3 && y < 6.5);
  if (x > 3.85 && x < 4.15 && y > 0.7 && y < 7.3 && !gap) return 100;
  return room(x, y);
}

bool passes_north(const msg::TaskAssignment& r) {
  for (std::size_t i = 0; i < r.n_path; ++i) {
    if (std::abs(r.path_xy[2 * i] - 4.0) < 0.5 && r.path_xy[2 * i + 1] > 5.0) return true;
  }
  return false;
}

// Issue 15: the protective field holds the robot in the south gap (something the map does
// not show stands in it). After blocks.replan_after it marks what blocks it and replans
// at once, through the north gap; the mark is forgotten after blocks.memory.
TEST(RobotExplorer, HeldByTheProtectiveFieldItMarksTheBlockAndReplansRoundIt) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, two_gaps);
  RobotExploreConfig cfg = explore_cfg();
  RobotExplorer ex(cfg, 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{3.2, 2.1, 0};
  (void)ex.step(map, at, 0, &bid, &route);
  ex.on_task(task(21, msg::TaskKind::kGoto, 6.0, 2.1));
  ASSERT_TRUE(ex.step(map, at, 10 * kNanosPerMilli, &bid, &route).route);
  EXPECT_FALSE(passes_north(route)) << "first through the south gap, the short way";
  // Held for 0.9 s: nothing yet; a different stop reason resets the hold.
  const Vec2 ahead(0.45, 0.0);  // the return that blocks, robot frame
  Nanos t = 20 * kNanosPerMilli;
  for (; t < 920 * kNanosPerMilli; t += 10 * kNanosPerMilli) ex.on_safety(StopReason::kProtectiveField, ahead, at, t);
  EXPECT_EQ(ex.counters().blocked_marks, 0u);
  EXPECT_FALSE(ex.step(map, at, t, &bid, &route).route);
  ex.on_safety(StopReason::kNone, ahead, at, t);
  const Nanos held = t + 10 * kNanosPerMilli;
  for (t = held; t <= held + kNanosPerSecond; t += 10 * kNanosPerMilli) ex.on_safety(StopReason::kProtectiveField, ahead, at, t);
  EXPECT_EQ(ex.counters().blocked_marks, 1u);
  const auto s = ex.step(map, at, t, &bid, &route);
  ASSERT_TRUE(s.route) << "replanned at once, not at the next period";
  EXPECT_EQ(route.kind, msg::TaskKind::kGoto);
  EXPECT_TRUE(passes_north(route)) << "round the block, through the north gap";
  EXPECT_NEAR(route.target_x, 6.0, 0.3);
  // Held on by the same return: its mark is renewed, not marked again into the ring.
  for (const Nanos until = t + 3 * kNanosPerSecond; t < until; t += 10 * kNanosPerMilli) {
    ex.on_safety(StopReason::kProtectiveField, ahead, at, t);
  }
  EXPECT_EQ(ex.counters().blocked_marks, 1u);
  // The mark is forgotten: the next period's plan takes the south gap again.
  const Nanos later = t + cfg.blocks.memory + 3 * kNanosPerSecond;
  ASSERT_TRUE(ex.step(map, at, later, &bid, &route).route);
  EXPECT_FALSE(passes_north(route));
}

// Keep right: held by a return 0.45 m ahead, the robot marks a disc there and, for
// keep_right_memory, a barrier keep_right_m long across its heading on its left, so the
// replan passes the block on its right. Held again by the same return with a new heading,
// the barrier turns with it and lasts again.
TEST(BlockMarks, AMarkClosesTheRobotsLeftOfTheReturnForAWhile) {
  explore::BlockMarksConfig cfg;
  ASSERT_DOUBLE_EQ(cfg.keep_right_m, 1.0);
  ASSERT_EQ(cfg.keep_right_memory, 5 * kNanosPerSecond);
  explore::BlockMarks marks(cfg);
  ClassGrid grid;
  grid.geometry = GridGeometry{0.1, -3.0, -3.0, 60, 60};
  auto fresh = [&] { grid.cells.assign(grid.geometry.cells(), Cell::kClear); };
  auto at = [&](double x, double y) {
    int i = 0, j = 0;
    EXPECT_TRUE(grid.geometry.cell_of(x, y, &i, &j));
    return grid.at(i, j);
  };
  const Pose2 east{0, 0, 0};
  const Vec2 ahead(0.45, 0.0);
  Nanos t = 0;
  for (; t <= cfg.replan_after; t += 10 * kNanosPerMilli) marks.on_safety(StopReason::kProtectiveField, ahead, east, t);
  ASSERT_EQ(marks.marked(), 1u);
  fresh();
  marks.stamp(&grid, t);
  EXPECT_EQ(at(0.45, 0.0), Cell::kObstacle);   // the disc
  EXPECT_EQ(at(0.45, 0.5), Cell::kObstacle);   // the barrier, north: the robot's left
  EXPECT_EQ(at(0.45, 0.95), Cell::kObstacle);  // its far end
  EXPECT_EQ(at(0.45, 1.3), Cell::kClear);      // beyond keep_right_m
  EXPECT_EQ(at(0.45, -0.5), Cell::kClear);     // the right stays open
  EXPECT_EQ(at(1.0, 0.5), Cell::kClear);       // a line, not a block
  fresh();
  marks.stamp(&grid, t + cfg.keep_right_memory + kNanosPerMilli);
  EXPECT_EQ(at(0.45, 0.0), Cell::kObstacle) << "the disc lasts blocked_memory_s";
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear) << "the barrier only keep_right_memory";
  // Held again by the same return (now on its right: it turned to face north): the barrier
  // runs west from the return, the robot's left, and lasts again.
  const Pose2 north{0, 0, std::numbers::pi / 2};
  const Nanos again = t + cfg.keep_right_memory + 2 * kNanosPerMilli;
  for (t = again; t <= again + 2 * cfg.replan_after; t += 10 * kNanosPerMilli)
    marks.on_safety(StopReason::kProtectiveField, Vec2(0.0, -0.45), north, t);
  EXPECT_EQ(marks.marked(), 1u) << "renewed, not marked again";
  fresh();
  marks.stamp(&grid, t);
  EXPECT_EQ(at(0.45, 0.0), Cell::kObstacle);
  EXPECT_EQ(at(-0.3, 0.0), Cell::kObstacle);  // west
  EXPECT_EQ(at(1.0, 0.0), Cell::kClear);      // east: its right
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear);     // the old barrier is gone
  // keep_right_m = 0: the disc alone, as before.
  cfg.keep_right_m = 0;
  explore::BlockMarks disc(cfg);
  for (t = 0; t <= cfg.replan_after; t += 10 * kNanosPerMilli) disc.on_safety(StopReason::kProtectiveField, ahead, east, t);
  fresh();
  disc.stamp(&grid, t);
  EXPECT_EQ(at(0.45, 0.0), Cell::kObstacle);
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear);
}

// Keep right is for what the map does not hold (another robot, a person): a return on a
// mapped obstacle (a wall, a door jamb at the robot's front right) gets the disc alone, so
// its barrier no longer closes the robot's own way. Judged mark by mark, on the map as
// given; stamp(..., false) leaves the barriers out but still counts them.
TEST(BlockMarks, AReturnOnTheMapGetsNoBarrier) {
  explore::BlockMarks marks(explore::BlockMarksConfig{});
  ClassGrid grid;
  grid.geometry = GridGeometry{0.1, -3.0, -3.0, 60, 60};
  auto set = [&](double x, double y, Cell c) {
    int i = 0, j = 0;
    ASSERT_TRUE(grid.geometry.cell_of(x, y, &i, &j));
    grid.at(i, j) = c;
  };
  auto at = [&](double x, double y) {
    int i = 0, j = 0;
    EXPECT_TRUE(grid.geometry.cell_of(x, y, &i, &j));
    return grid.at(i, j);
  };
  auto jamb = [&] {  // the jamb's cells, 0.3 m beyond the return 0.45 m ahead
    grid.cells.assign(grid.geometry.cells(), Cell::kClear);
    set(0.75, 0.0, Cell::kObstacle);
    set(0.75, -0.1, Cell::kObstacle);
  };
  const Pose2 east{0, 0, 0};
  Nanos t = 0;
  for (; t <= kNanosPerSecond; t += 10 * kNanosPerMilli) marks.on_safety(StopReason::kProtectiveField, Vec2(0.45, 0.0), east, t);
  ASSERT_EQ(marks.marked(), 1u);
  jamb();
  EXPECT_EQ(marks.stamp(&grid, t), 1u) << "0.3 m from the jamb: not on the map";
  EXPECT_EQ(at(0.45, 0.5), Cell::kObstacle);
  // The same return with the jamb under it: the disc, no barrier.
  jamb();
  set(0.45, 0.0, Cell::kObstacle);
  EXPECT_EQ(marks.stamp(&grid, t), 0u);
  EXPECT_EQ(at(0.35, 0.0), Cell::kObstacle) << "the disc";
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear) << "no barrier from a return on the map";
  // One cell off the obstacle (returns fall on either side of a cell's edge): on the map.
  jamb();
  set(0.55, 0.0, Cell::kObstacle);
  EXPECT_EQ(marks.stamp(&grid, t), 0u);
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear);
  // Without barriers: the disc alone, the barrier still counted (the caller's yield test).
  jamb();
  EXPECT_EQ(marks.stamp(&grid, t, /*barriers=*/false), 1u);
  EXPECT_EQ(at(0.45, 0.0), Cell::kObstacle);
  EXPECT_EQ(at(0.45, 0.5), Cell::kClear);
  EXPECT_EQ(marks.next_barrier_end(t), kNanosPerSecond + explore::BlockMarksConfig{}.keep_right_memory);
  EXPECT_EQ(marks.next_barrier_end(t + explore::BlockMarksConfig{}.keep_right_memory), -1);
}

// A corridor 1.8 m wide (y in [1, 2.8]) from x = 0.7 to 9; beyond, nothing is known.
std::uint8_t corridor(double x, double y) {
  if (x > 9.0) return kMapTileUnknown;
  return x < 0.7 || y < 1.0 || y > 2.8 ? 100 : 0;
}

// Keep right where the right is a wall: the robot hugs the corridor's south wall and
// another robot holds it head-on. The barrier closes its left, the wall its right: it
// yields (stands, reported as yielding, not as a failed plan, so cairn-robot does not
// report it stuck) and replans when the barrier ends, before any period, round the held
// return's north side. Before, it stood with a failed plan until the next period.
TEST(RobotExplorer, ARobotWhoseRightIsClosedYieldsAndGoesOnWhenTheBarrierEnds) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, corridor);
  RobotExploreConfig cfg = explore_cfg();
  cfg.bid_period = 600 * kNanosPerSecond;  // no period in this test
  RobotExplorer ex(cfg, 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{2.0, 1.4, 0};
  (void)ex.step(map, at, 0, &bid, &route);
  ex.on_task(task(31, msg::TaskKind::kGoto, 6.0, 1.9));
  ASSERT_TRUE(ex.step(map, at, 10 * kNanosPerMilli, &bid, &route).route);
  ASSERT_EQ(route.kind, msg::TaskKind::kGoto);
  EXPECT_FALSE(ex.yielding());
  Nanos t = 20 * kNanosPerMilli;
  for (; ex.counters().blocked_marks == 0 && t < 3 * kNanosPerSecond; t += 10 * kNanosPerMilli)
    ex.on_safety(StopReason::kProtectiveField, Vec2(0.45, 0.0), at, t);
  ASSERT_EQ(ex.counters().blocked_marks, 1u);
  const Nanos marked = t - 10 * kNanosPerMilli;
  ASSERT_TRUE(ex.step(map, at, t, &bid, &route).route);
  EXPECT_EQ(route.kind, msg::TaskKind::kIdle) << "stands while the other passes";
  EXPECT_TRUE(ex.yielding());
  EXPECT_EQ(ex.counters().yields, 1u);
  EXPECT_EQ(ex.counters().plan_failures, 0u);
  ex.on_safety(StopReason::kNone, Vec2(0.45, 0.0), at, t);
  const Nanos ends = marked + cfg.blocks.keep_right_memory;
  EXPECT_FALSE(ex.step(map, at, ends - 10 * kNanosPerMilli, &bid, &route).route) << "no replan while the barrier lasts";
  ASSERT_TRUE(ex.step(map, at, ends + 10 * kNanosPerMilli, &bid, &route).route) << "replanned when the barrier ended";
  EXPECT_EQ(route.kind, msg::TaskKind::kGoto);
  EXPECT_FALSE(ex.yielding());
  ASSERT_GE(route.n_path, 3);
  bool north = false;  // round the disc (it lasts blocks.memory), on the robot's left now
  for (std::size_t i = 0; i < route.n_path; ++i) {
    if (std::abs(route.path_xy[2 * i] - 2.45) < 0.2) north = north || route.path_xy[2 * i + 1] > 1.75;
  }
  EXPECT_TRUE(north);
}

// Yielding is told apart from a dead end: with the same barrier up, a goal no path reaches
// even without barriers (inside the corridor's south wall) is a failed plan, not a yield
// (the base's monitor must take that task back). And a new task ends a yield at once.
TEST(RobotExplorer, AGoalNoPathReachesIsAFailureNotAYieldAndANewTaskEndsAYield) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, corridor);
  RobotExploreConfig cfg = explore_cfg();
  cfg.bid_period = 600 * kNanosPerSecond;
  RobotExplorer ex(cfg, 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{2.0, 1.4, 0};
  (void)ex.step(map, at, 0, &bid, &route);
  ex.on_task(task(31, msg::TaskKind::kGoto, 6.0, 1.9));
  ASSERT_TRUE(ex.step(map, at, 10 * kNanosPerMilli, &bid, &route).route);
  Nanos t = 20 * kNanosPerMilli;
  for (; ex.counters().blocked_marks == 0 && t < 3 * kNanosPerSecond; t += 10 * kNanosPerMilli)
    ex.on_safety(StopReason::kProtectiveField, Vec2(0.45, 0.0), at, t);
  ASSERT_EQ(ex.counters().blocked_marks, 1u);
  ASSERT_TRUE(ex.step(map, at, t, &bid, &route).route);
  ASSERT_TRUE(ex.yielding());
  ex.on_safety(StopReason::kNone, Vec2(0.45, 0.0), at, t);
  ex.on_task(task(32, msg::TaskKind::kGoto, 6.0, 0.2));
  EXPECT_FALSE(ex.yielding()) << "a new task ends the yield";
  ASSERT_TRUE(ex.step(map, at, t + 10 * kNanosPerMilli, &bid, &route).route);
  EXPECT_EQ(route.kind, msg::TaskKind::kIdle);
  EXPECT_FALSE(ex.yielding()) << "no path with or without the barrier: a dead end";
  EXPECT_EQ(ex.counters().plan_failures, 1u);
  EXPECT_EQ(ex.counters().yields, 1u);
}

// The marks are stamped into a copy of the classified map for each plan: an expired mark
// no longer closes the way at the next replan, even before the next period classifies the
// map again (stamped into the map itself, marks piled up between periods).
TEST(RobotExplorer, AnExpiredMarkNoLongerClosesTheWayBeforeTheNextPeriod) {
  GlobalMap map(map_cfg(4));
  fill(&map, 2, 2, two_gaps);
  RobotExploreConfig cfg = explore_cfg();
  cfg.bid_period = 600 * kNanosPerSecond;  // no period (and no new classification) in this test
  cfg.blocks.memory = kNanosPerSecond;
  cfg.blocks.keep_right_memory = kNanosPerSecond;
  RobotExplorer ex(cfg, 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  const Pose2 at{3.2, 2.1, 0};
  (void)ex.step(map, at, 0, &bid, &route);
  ex.on_task(task(21, msg::TaskKind::kGoto, 6.0, 2.1));
  ASSERT_TRUE(ex.step(map, at, 10 * kNanosPerMilli, &bid, &route).route);
  EXPECT_FALSE(passes_north(route));
  Nanos t = 20 * kNanosPerMilli;
  for (; ex.counters().blocked_marks == 0 && t < 3 * kNanosPerSecond; t += 10 * kNanosPerMilli)
    ex.on_safety(StopReason::kProtectiveField, Vec2(0.45, 0.0), at, t);
  ASSERT_EQ(ex.counters().blocked_marks, 1u);
  ASSERT_TRUE(ex.step(map, at, t, &bid, &route).route);
  EXPECT_TRUE(passes_north(route)) << "round the mark";
  ex.on_safety(StopReason::kNone, Vec2(0.45, 0.0), at, t);
  // The mark has expired; a new task (same target) is planned before any new period.
  const Nanos later = t + 2 * kNanosPerSecond;
  ex.on_task(task(22, msg::TaskKind::kGoto, 6.0, 2.1));
  ASSERT_TRUE(ex.step(map, at, later, &bid, &route).route);
  EXPECT_FALSE(passes_north(route)) << "the expired mark still closed the south gap";
}

// Held with a non-finite pose or return: nothing is marked (a NaN mark would never be
// renewed, and would push real marks out of the ring).
TEST(BlockMarks, NonFiniteInputsMarkNothing) {
  explore::BlockMarksConfig cfg;
  explore::BlockMarks marks(cfg);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Nanos t = 0; t <= 3 * cfg.replan_after; t += 10 * kNanosPerMilli) {
    marks.on_safety(StopReason::kProtectiveField, Vec2(nan, 0.0), Pose2{0, 0, 0}, t);
    marks.on_safety(StopReason::kProtectiveField, Vec2(0.45, 0.0), Pose2{0, 0, std::numeric_limits<double>::infinity()}, t);
  }
  EXPECT_EQ(marks.marked(), 0u);
}

// A map's resolution comes from the network. A hostile tiny one must not make stamping
// loop for hours (a 1e-7 m grid put a 0.15 m disc 1.5 million cells across: 10^13 steps):
// the work is capped by the grid's own size.
TEST(BlockMarks, StampingATinyResolutionGridIsBoundedByTheGrid) {
  explore::BlockMarksConfig cfg;
  explore::BlockMarks marks(cfg);
  for (Nanos t = 0; t <= cfg.replan_after; t += 10 * kNanosPerMilli)
    marks.on_safety(StopReason::kProtectiveField, Vec2(0.0, 0.0), Pose2{0, 0, 0}, t);
  ASSERT_EQ(marks.marked(), 1u);
  ClassGrid grid;
  grid.geometry = GridGeometry{1e-7, -2e-6, -2e-6, 40, 40};
  grid.cells.assign(grid.geometry.cells(), Cell::kClear);
  marks.stamp(&grid, cfg.replan_after);
  EXPECT_EQ(grid.at(20, 20), Cell::kObstacle);  // the whole 4 µm grid lies inside the 0.15 m disc
  EXPECT_EQ(grid.at(0, 0), Cell::kObstacle);
}

TEST(RobotExplorer, WithoutAMapItBidsNothingAndStandsOnATask) {
  GlobalMap map(map_cfg(4));
  RobotExplorer ex(explore_cfg(), 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  ex.on_task(task(3, msg::TaskKind::kGoto, 5, 5));
  const auto s = ex.step(map, Pose2{1, 1, 0}, 0, &bid, &route);
  EXPECT_FALSE(s.bid);
  ASSERT_TRUE(s.route);
  EXPECT_EQ(route.kind, msg::TaskKind::kIdle) << "no plan: stand, the base's monitor takes the task back";
  EXPECT_EQ(ex.counters().plan_failures, 1u);
}

TEST(RobotExplorer, APathLongerThanATaskHoldsIsCutAndItsLastKeptPointIsTheLeg) {
  // A 38 m clear corridor, 9.6 m wide.
  GlobalMap map(map_cfg(4));
  fill(&map, 4, 1, [](double, double y) -> std::uint8_t { return y < 0.5 || y > 9.1 ? 100 : 0; });
  RobotExplorer ex(explore_cfg(), 5, map_cfg(4).max_cells);
  msg::Bid bid;
  msg::TaskAssignment route;
  ex.on_task(task(4, msg::TaskKind::kGoto, 37.0, 4.8));
  const auto s = ex.step(map, Pose2{1.0, 4.8, 0}, 0, &bid, &route);
  ASSERT_TRUE(s.route);
  EXPECT_EQ(route.kind, msg::TaskKind::kGoto);
  EXPECT_EQ(route.n_path, msg::kMaxPath);
  EXPECT_EQ(ex.counters().paths_cut, 1u);
  // 65 points 0.30 m apart from x = 1: the leg ends near x = 20.5, not at 37.
  EXPECT_NEAR(route.target_x, 1.0 + 65 * 0.30, 0.5);
  EXPECT_GT(route.target_x, route.path_xy[2 * (msg::kMaxPath - 1)]);
}

}  // namespace
}  // namespace cairn::firmware
