// GridPlanner on hand-made maps: a straight corridor gives the straight path, a wall
// forces the detour through its door, a door narrower than the robot is avoided when
// another is open, unknown cells are never crossed, a start inside the inflation still
// plans, a goal on an obstacle ends on the nearest reachable clear cell within the
// tolerance, refusals, and every waypoint is a clear cell.
#include "firmware/explore/grid_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace cairn::explore {
namespace {

constexpr double kRes = 0.15;

struct Map {
  GridGeometry g;
  std::vector<Cell> c;
  Map(int w, int h) : g{kRes, 0, 0, w, h}, c(g.cells(), Cell::kUnknown) {}
  void fill(int i0, int j0, int i1, int j1, Cell v) {
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) c[g.index(i, j)] = v;
  }
  Vec2 at(int i, int j) const { return g.center(i, j); }
  Cell cell(Vec2 p) const {
    int i = 0, j = 0;
    EXPECT_TRUE(g.cell_of(p.x(), p.y(), &i, &j));
    return c[g.index(i, j)];
  }
};

GridPlannerConfig config() {
  GridPlannerConfig c;
  c.max_cells = 10000;
  c.robot_radius_m = 0.30;
  c.waypoint_spacing_m = 0.45;
  return c;
}

double length(Vec2 start, const std::vector<Vec2>& p) {
  double l = 0;
  Vec2 a = start;
  for (const Vec2& b : p) {
    l += (b - a).norm();
    a = b;
  }
  return l;
}

TEST(GridPlanner, OpenRoomGivesTheStraightPathEndingOnTheGoal) {
  Map m(40, 20);
  m.fill(0, 0, 39, 19, Cell::kClear);
  GridPlanner p(config());
  std::vector<Vec2> path;
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(5, 10), m.at(35, 10), &path), PlanStatus::kOk);
  ASSERT_FALSE(path.empty());
  EXPECT_NEAR((path.back() - m.at(35, 10)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(length(m.at(5, 10), path), 30 * kRes, 1e-9);
  for (std::size_t k = 1; k < path.size(); ++k) EXPECT_LE((path[k] - path[k - 1]).norm(), 0.45 + 1e-9);
}

TEST(GridPlanner, WallForcesTheDetourThroughTheWideDoorNotTheNarrowOne) {
  // A wall at i = 20 with a 2-cell gap (30 cm, narrower than the 60 cm robot) near the
  // straight line and a 10-cell door (1.5 m) far up.
  Map m(40, 60);
  m.fill(0, 0, 39, 59, Cell::kClear);
  m.fill(20, 0, 20, 59, Cell::kObstacle);
  m.fill(20, 10, 20, 11, Cell::kClear);  // narrow gap
  m.fill(20, 45, 20, 54, Cell::kClear);  // door
  GridPlanner p(config());
  std::vector<Vec2> path;
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(5, 10), m.at(35, 10), &path), PlanStatus::kOk);
  bool through_door = false;
  for (const Vec2& w : path) {
    EXPECT_EQ(m.cell(w), Cell::kClear);
    int i = 0, j = 0;
    ASSERT_TRUE(m.g.cell_of(w.x(), w.y(), &i, &j));
    if (i >= 19 && i <= 21) {
      EXPECT_GE(j, 45);
      EXPECT_LE(j, 54);
      through_door = true;
    }
  }
  EXPECT_TRUE(through_door);
  EXPECT_GT(length(m.at(5, 10), path), 2 * 35 * kRes);  // the long way round
}

TEST(GridPlanner, AStartInTheWallsBandDoesNotSlipAlongItIntoTheNarrowGap) {
  // The same wall; the robot starts two cells from it (inside the inflated band, 18, 10),
  // level with the gap. Along the band through the gap is ~1.3 m; by the door ~11 m.
  Map m(40, 60);
  m.fill(0, 0, 39, 59, Cell::kClear);
  m.fill(20, 0, 20, 59, Cell::kObstacle);
  m.fill(20, 10, 20, 11, Cell::kClear);
  m.fill(20, 45, 20, 54, Cell::kClear);
  GridPlanner p(config());
  std::vector<Vec2> path;
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(18, 10), m.at(35, 10), &path), PlanStatus::kOk);
  bool through_door = false;
  for (const Vec2& w : path) {
    int i = 0, j = 0;
    ASSERT_TRUE(m.g.cell_of(w.x(), w.y(), &i, &j));
    if (i >= 19 && i <= 21) {
      EXPECT_GE(j, 45) << "through the 30 cm gap";
      through_door = true;
    }
  }
  EXPECT_TRUE(through_door);
}

TEST(GridPlanner, UnknownCellsAreNeverCrossed) {
  Map m(40, 20);
  m.fill(0, 0, 39, 19, Cell::kClear);
  m.fill(20, 0, 20, 16, Cell::kUnknown);  // an unknown band with a way round at j >= 17
  GridPlanner p(config());
  std::vector<Vec2> path;
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(5, 2), m.at(35, 2), &path), PlanStatus::kOk);
  for (const Vec2& w : path) EXPECT_EQ(m.cell(w), Cell::kClear);
  m.fill(20, 0, 20, 19, Cell::kUnknown);  // closed: no path
  EXPECT_EQ(p.plan(m.g, m.c.data(), m.at(5, 2), m.at(35, 2), &path), PlanStatus::kNoPath);
  EXPECT_TRUE(path.empty());
}

// The cells under a robot that has not moved yet are unknown (its laser is mounted ahead of
// its centre); its footprint is free all the same, so it plans out of it.
TEST(GridPlanner, StartWhoseOwnCellsAreUnseenStillPlans) {
  Map m(40, 20);
  m.fill(7, 3, 35, 16, Cell::kClear);  // the robot at (5, 10): its cell and the next unknown
  GridPlanner p(config());
  std::vector<Vec2> path;
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(5, 10), m.at(30, 10), &path), PlanStatus::kOk);
  EXPECT_NEAR((path.back() - m.at(30, 10)).norm(), 0.0, 1e-12);
  // Unknown cells beyond the footprint are still never entered.
  for (const Vec2& w : path) EXPECT_TRUE(m.cell(w) == Cell::kClear || (w - m.at(5, 10)).norm() <= 0.30) << w.transpose();
}

TEST(GridPlanner, StartInsideTheInflationStillPlans) {
  Map m(40, 20);
  m.fill(0, 0, 39, 19, Cell::kClear);
  m.fill(0, 0, 39, 0, Cell::kObstacle);
  GridPlanner p(config());
  std::vector<Vec2> path;
  // One cell off the wall (inflated: 30 cm radius, 15 cm cells) to the middle of the room.
  ASSERT_EQ(p.plan(m.g, m.c.data(), m.at(5, 1), m.at(30, 10), &path), PlanStatus::kOk);
  EXPECT_NEAR((path.back() - m.at(30, 10)).norm(), 0.0, 1e-12);
}

TEST(GridPlanner, GoalOnAnObstacleEndsOnTheNearestReachableClearCellWithinTolerance) {
  Map m(40, 20);
  m.fill(0, 0, 39, 19, Cell::kClear);
  m.fill(30, 0, 39, 19, Cell::kObstacle);  // the goal (32, 10) is 3 cells inside the wall
  GridPlanner p(config());
  std::vector<Vec2> path;
  // Cells i <= 27 are free of the inflation (30 cm = 2 cells); (28, 10) and (29, 10) are
  // inflated but the goal region admits only the goal cell itself past the inflation rule,
  // so the nearest reachable cell is (27, 10), 5 cells = 0.75 m from the goal.
  EXPECT_EQ(p.plan(m.g, m.c.data(), m.at(5, 10), m.at(32, 10), &path), PlanStatus::kNoPath);  // 0.45 m: none
  GridPlannerConfig wide = config();
  wide.goal_tolerance_m = 0.80;
  GridPlanner q(wide);
  ASSERT_EQ(q.plan(m.g, m.c.data(), m.at(5, 10), m.at(32, 10), &path), PlanStatus::kOk);
  EXPECT_NEAR((path.back() - m.at(27, 10)).norm(), 0.0, 1e-12);
}

TEST(GridPlanner, Refusals) {
  Map m(40, 20);
  m.fill(0, 0, 39, 19, Cell::kClear);
  m.fill(30, 5, 30, 5, Cell::kObstacle);
  GridPlanner p(config());
  std::vector<Vec2> path;
  EXPECT_EQ(p.plan(m.g, m.c.data(), Vec2(-1, 0), m.at(5, 5), &path), PlanStatus::kStartOutsideMap);
  EXPECT_EQ(p.plan(m.g, m.c.data(), m.at(5, 5), Vec2(100, 0), &path), PlanStatus::kGoalOutsideMap);
  EXPECT_EQ(p.plan(m.g, nullptr, m.at(5, 5), m.at(6, 5), &path), PlanStatus::kBadMap);
  Map big(200, 100);
  EXPECT_EQ(p.plan(big.g, big.c.data(), big.at(5, 5), big.at(6, 5), &path), PlanStatus::kMapTooLarge);
  GridPlannerConfig bad = config();
  bad.inflated_cost_factor = 0.5;
  EXPECT_THROW(GridPlanner{bad}, std::invalid_argument);
  bad = config();
  bad.max_cells = 0;
  EXPECT_THROW(GridPlanner{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace cairn::explore
