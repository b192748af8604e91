// cairn-sim's exploration mode on the office world (the seed's world A) with two robots:
// the map's coverage grows to a stated level within a stated simulated time, the run is
// deterministic, the robots seldom press against walls, and the base's allocator keeps
// the two robots on different frontiers (coordination), which the uncoordinated mode
// does not. Capped at 120 simulated s for CI (three runs, about 25 s wall under nice).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>

#include "tools/sim/fleet_sim.hpp"

namespace cairn {
namespace {

constexpr double kSeconds = 120;

sim::FleetSimConfig office_explore(std::uint64_t seed) {
  sim::FleetSimConfig c;
  c.world_path = std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world";
  c.robots = 2;
  c.duration_s = kSeconds;
  c.seed = seed;
  c.threads = 2;
  c.robot.safety.max_v = 1.0;
  c.explore = true;
  c.coverage_period = 5 * kNanosPerSecond;
  return c;
}

struct Outcome {
  sim::FleetSummary s;
  std::vector<sim::RobotSample> samples;
};

Outcome run(std::uint64_t seed) {
  sim::FleetSim f(office_explore(seed));
  f.run();
  return {f.summary(1.0), f.samples()};
}

const Outcome& first() {
  static const Outcome r = run(5);
  return r;
}

TEST(ExploreSim, CoverageGrowsToSeventyPercentWithinTwoMinutes) {
  const sim::FleetSummary& s = first().s;
  ASSERT_GE(s.coverage.size(), 20u);
  EXPECT_LT(s.coverage.front().coverage, 0.05);  // nothing mapped at t = 0
  for (std::size_t k = 4; k < s.coverage.size(); k += 4)
    EXPECT_GT(s.coverage[k].coverage, s.coverage[k - 4].coverage) << "stalled before t = " << s.coverage[k].t_s;
  ASSERT_TRUE(s.time_to_coverage[0].has_value());
  EXPECT_LE(*s.time_to_coverage[0], 70.0);  // 50 % within 70 s (seed 5: 45 s)
  EXPECT_GE(s.coverage.back().coverage, 0.70);  // seed 5: 0.79
  EXPECT_GE(s.map.agreement, 0.85);
}

TEST(ExploreSim, RobotsDriveAndSeldomPressAgainstWalls) {
  const sim::FleetSummary& s = first().s;
  ASSERT_EQ(s.robots.size(), 2u);
  for (const auto& r : s.robots) {
    EXPECT_GT(r.distance_m, 20.0) << "robot " << r.id;
    // bumps: physics steps (5 ms) in which the body was blocked; 200 = 1 s of contact (seed 5: 0).
    EXPECT_LE(r.bumps, 200u) << "robot " << r.id;
  }
}

TEST(ExploreSim, TheAllocatorCoordinatesTheRobots) {
  const sim::FleetSummary& s = first().s;
  ASSERT_TRUE(s.explore.has_value());
  const auto& d = s.explore->driver;
  const auto& a = s.explore->allocator;
  EXPECT_GE(a.explore_assigned, 4u);
  // A plan fails when the map closed the way to a target after the bid (a frontier in a
  // doorway that newer scans narrowed): the robot stands until the monitor reassigns it.
  // Rare, not never: seed 5 has 1 of 181 plans (0 before scans were placed at the frames
  // of their times, which changed the run); a planner that fails often trips this.
  EXPECT_GT(d.plans, 100u);
  EXPECT_LE(d.plan_failures * 50, d.plans);
  // Bid periods (2 s) with both robots on explore tasks on different frontiers: most of them.
  EXPECT_GE(d.periods_on_distinct_frontiers, static_cast<std::uint64_t>(kSeconds / 2 * 0.75));
}

// Without the discount (the seed's uncoordinated mode) each robot takes its own best
// item: the two robots, starting side by side, chase the same frontier far more often.
TEST(ExploreSim, UncoordinatedRobotsShareFrontiersMoreOften) {
  sim::FleetSimConfig c = office_explore(5);
  c.exploration.allocator.coordinated = false;
  sim::FleetSim f(c);
  f.run();
  const sim::FleetSummary u = f.summary(1.0);
  std::printf("bid periods on different frontiers: coordinated %llu, uncoordinated %llu\n",
              static_cast<unsigned long long>(first().s.explore->driver.periods_on_distinct_frontiers),
              static_cast<unsigned long long>(u.explore->driver.periods_on_distinct_frontiers));
  EXPECT_LT(u.explore->driver.periods_on_distinct_frontiers, first().s.explore->driver.periods_on_distinct_frontiers);
}

TEST(ExploreSim, SameSeedSameRun) {
  const Outcome& a = first();
  const Outcome b = run(5);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); ++i)
    ASSERT_EQ(std::memcmp(&a.samples[i].truth, &b.samples[i].truth, sizeof a.samples[i].truth), 0) << "sample " << i;
  ASSERT_EQ(a.s.coverage.size(), b.s.coverage.size());
  for (std::size_t i = 0; i < a.s.coverage.size(); ++i) EXPECT_EQ(a.s.coverage[i].coverage, b.s.coverage[i].coverage);
  EXPECT_EQ(a.s.explore->allocator.assignments_emitted, b.s.explore->allocator.assignments_emitted);
  EXPECT_EQ(a.s.explore->driver.plans, b.s.explore->driver.plans);
}

}  // namespace
}  // namespace cairn
