// cairn-sim's exploration mode on the office world (the seed's world A) with two robots in
// one world (they see each other and would collide): the map's coverage grows to a stated
// level within a stated simulated time, the run is deterministic, the robots seldom press
// against walls and never touch each other (their protective fields; without them they
// collide, and these tests fail), and the base's allocator keeps
// the two robots on different frontiers (coordination), which the uncoordinated mode
// does not. Capped at 120 simulated s for CI (three runs, about 25 s wall under nice), plus
// a 70 s corridor run of two robots meeting head-on (about 4 s).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

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
  c.shared_world = true;  // the robots see each other and collide; their protective fields keep them apart
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

// The map is also scored against the space the robots' bodies (0.3 m discs) can sweep. In
// the office every free cell is swept (no gap is narrower than the robot; a corner's free
// cell lies within 0.3 m of where the disc's centre can go), so the two coverages agree;
// random clutter is where they differ (docs/explore.md, "Drivable coverage").
TEST(ExploreSim, CoverageIsAlsoScoredAgainstWhereTheRobotsCanDrive) {
  const sim::FleetSummary& s = first().s;
  EXPECT_DOUBLE_EQ(s.map.robot_radius_m, 0.3);
  EXPECT_EQ(s.map.drivable_cells, s.map.free_cells);
  EXPECT_EQ(s.map.known_drivable, s.map.known_free);
  EXPECT_DOUBLE_EQ(s.coverage.back().drivable, s.map.drivable_coverage);
  EXPECT_GT(s.coverage.back().drivable, 0.70);
}

TEST(ExploreSim, RobotsDriveAndSeldomPressAgainstWalls) {
  const sim::FleetSummary& s = first().s;
  ASSERT_EQ(s.robots.size(), 2u);
  for (const auto& r : s.robots) {
    EXPECT_GT(r.distance_m, 20.0) << "robot " << r.id;
    // bumps: physics steps (5 ms) in which the body was blocked, by a wall or the other
    // robot; 200 = 1 s of contact (seed 5: 0).
    EXPECT_LE(r.bumps, 200u) << "robot " << r.id;
  }
  // In one world they see each other: sightings are fused.
  EXPECT_GT(s.robot_observations_used, 0u);
  // They never touch: the bodies (0.3 m) stay more than 0.6 m apart.
  double closest = 1e9;
  const auto& x = first().samples;
  for (std::size_t a = 0; a + 1 < x.size(); ++a) {
    if (x[a + 1].t == x[a].t) closest = std::min(closest, std::hypot(x[a].truth.x - x[a + 1].truth.x, x[a].truth.y - x[a + 1].truth.y));
  }
  std::printf("closest approach of the two robots: %.3f m\n", closest);
  EXPECT_GT(closest, 0.6);
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

// An operator's visit request (cairn-sim --visit): at 30 s robot 2 is asked to go to
// (12.5, 10), in the corridor; it leaves its frontier, gets there, and the allocator counts
// the arrival. A request for a robot the base does not know (9) is refused by the base's
// checks, as cairn-base refuses it; so is one at 3 s for robot 1 to the far corner room
// (22, 17), which the map does not hold yet (paths never enter unknown cells): at once,
// not after the robot has stood and reported itself stuck (visits_failed stays 0).
TEST(ExploreSim, AVisitRequestSendsTheRobotThereAndBack) {
  sim::FleetSimConfig c = office_explore(5);
  c.duration_s = 90;
  const Vec2 target(12.5, 10.0);
  c.exploration.visits = {sim::ScheduledVisit::parse("30:2:12.5:10"), sim::ScheduledVisit::parse("31:9:1:1"),
                          sim::ScheduledVisit::parse("3:1:22:17")};
  sim::FleetSim f(c);
  f.run();
  const sim::FleetSummary s = f.summary(1.0);
  ASSERT_TRUE(s.explore.has_value());
  EXPECT_EQ(s.explore->driver.visits_taken, 1u);
  EXPECT_EQ(s.explore->driver.visits_refused, 2u);
  EXPECT_EQ(s.explore->allocator.visits_requested, 1u);
  EXPECT_EQ(s.explore->allocator.visits_arrived, 1u);
  EXPECT_EQ(s.explore->allocator.visits_failed, 0u);
  double before = 1e9, after = 1e9, arrived_at = -1, last = 0;
  for (const sim::RobotSample& r : f.samples()) {
    if (r.robot != 2) continue;
    const double d = (r.truth.translation() - target).norm();
    last = d;
    if (r.t < 30 * kNanosPerSecond) {
      before = std::min(before, d);
    } else if (d < after) {
      after = d;
      if (d < 0.5 && arrived_at < 0) arrived_at = nanos_to_seconds(r.t);
    }
  }
  std::printf("robot 2: closest to the target %.2f m before the request, %.2f m after (within 0.5 m at %.1f s)\n", before,
              after, arrived_at);
  EXPECT_GT(before, 1.0) << "the robot was not there anyway";
  EXPECT_LT(after, 0.5);
  EXPECT_LT(arrived_at, 60.0);
  std::printf("robot 2 ends %.2f m from the target\n", last);
  EXPECT_GT(last, 2.0) << "back to exploring after the visit";
}

TEST(ExploreSim, AVisitIsWrittenTimeRobotXY) {
  const sim::ScheduledVisit v = sim::ScheduledVisit::parse("12.5:3:-1:2.25");
  EXPECT_EQ(v.at, 12500 * kNanosPerMilli);
  EXPECT_EQ(v.robot, 3);
  EXPECT_EQ(v.target, Vec2(-1, 2.25));
  for (const char* bad : {"", "1:2:3", "1:2:3:4:5", "x:1:2:3", "-1:1:0:0", "1:0:0:0", "1:70000:0:0", "1:1:0:0 ",
                          "1: 1:0:0", "1:-1:0:0", "1:-4294967295:0:0", "1:99999999999999999999:0:0", "1:1:nan:0",
                          "1:1:0:inf", "1:1:20000:0", "1e400:1:0:0", "::::"}) {
    EXPECT_THROW(sim::ScheduledVisit::parse(bad), std::invalid_argument) << "'" << bad << "'";
  }
}

// Two robots sent to each other's start along a 3 m corridor meet head-on, each held by
// the other's body in its protective field. Keeping right (BlockMarks' barrier to the
// robot's left of what holds it), they pass on opposite sides, 11.7 s after first coming
// within 1 m. With the disc alone (keep_right_m = 0, the behaviour before) both replanned
// round the same side, met again, and had not passed 70 s into the run (measured once with
// corridor_pass(0.0); not run here, to keep the suite short).
struct PassOutcome {
  double first_close_s = -1;  // centres first within 1 m
  double passed_s = -1;       // robot 1 first 0.6 m east of robot 2 (they started the other way round)
  double closest_m = 1e9;     // centre to centre
};

PassOutcome corridor_pass(double keep_right_m) {
  const std::string world = testing::TempDir() + "/corridor_pass.world";
  {
    std::FILE* f = std::fopen(world.c_str(), "w");
    if (f == nullptr) throw std::runtime_error("cannot write " + world);
    std::fputs("bounds 0 0 18 3\nbox 0 0 18 3\npole 4 0.4 0.05\npole 9 2.6 0.05\npole 14 0.4 0.05\n"
               "start 1 2 1.4 0\nstart 2 16 1.6 3.14159\n",
               f);
    std::fclose(f);
  }
  sim::FleetSimConfig c = office_explore(3);
  c.world_path = world;
  c.duration_s = 70;
  c.exploration.blocks.keep_right_m = keep_right_m;
  c.exploration.visits = {sim::ScheduledVisit::parse("3:1:16:1.5"), sim::ScheduledVisit::parse("3:2:2:1.5")};
  sim::FleetSim f(c);
  f.run();
  Vec2 at[2] = {Vec2::Zero(), Vec2::Zero()};
  PassOutcome out;
  for (const sim::RobotSample& r : f.samples()) {
    at[r.robot - 1] = r.truth.translation();
    if (r.robot != 2) continue;
    const double t = nanos_to_seconds(r.t), d = (at[0] - at[1]).norm();
    out.closest_m = std::min(out.closest_m, d);
    if (out.first_close_s < 0 && d < 1.0) out.first_close_s = t;
    if (out.passed_s < 0 && at[0].x() > at[1].x() + 0.6) out.passed_s = t;
  }
  return out;
}

TEST(ExploreSim, RobotsMeetingHeadOnInACorridorPassKeepingRight) {
  const PassOutcome keep = corridor_pass(explore::BlockMarksConfig{}.keep_right_m);
  std::printf("corridor: close at %.1f s, passed at %.1f s keeping right; closest %.2f m\n", keep.first_close_s,
              keep.passed_s, keep.closest_m);
  ASSERT_GT(keep.first_close_s, 0) << "the robots never met";
  ASSERT_GT(keep.passed_s, 0) << "never passed";
  EXPECT_LT(keep.passed_s - keep.first_close_s, 15.0);
  EXPECT_GT(keep.closest_m, 0.6) << "bodies (0.3 m) touched";
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
