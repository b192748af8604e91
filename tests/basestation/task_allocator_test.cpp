// The exploration executive driven with hand-made bids on simulated time (plain Nanos, no
// sleeps): the IGR-overlap discount, hysteresis, the threshold, the wait for bids, a user
// visit, no-progress take-back with an expiring bar, link loss and the end of exploration.
#include "basestation/explore/task_allocator.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::explore {
namespace {

using msg::TaskKind;

Nanos sec(double s) { return static_cast<Nanos>(std::llround(s * 1e9)); }

msg::BidItem item(double x, double y, double gain, double cost, Rect igr) {
  msg::BidItem it;
  it.x = x;
  it.y = y;
  it.gain = gain;
  it.cost = cost;
  it.igr_min_x = igr.min_x;
  it.igr_min_y = igr.min_y;
  it.igr_max_x = igr.max_x;
  it.igr_max_y = igr.max_y;
  return it;
}

msg::Bid bid(std::uint16_t robot, std::initializer_list<msg::BidItem> items) {
  msg::Bid b;
  b.robot_id = robot;
  for (const auto& it : items) b.items[b.n_items++] = it;
  return b;
}

AllocatorConfig test_config() {
  AllocatorConfig c;
  c.bid_wait = sec(0.5);
  c.cells_per_metre = 1.0;
  c.min_gain = 20;
  return c;
}

// Runs one tick and returns what it emitted.
std::vector<msg::TaskAssignment> tick(TaskAllocator& a, Nanos now, bool* ended = nullptr) {
  std::vector<msg::TaskAssignment> out;
  const bool e = a.tick(now, &out);
  if (ended != nullptr) *ended = e;
  return out;
}

const msg::TaskAssignment* for_robot(const std::vector<msg::TaskAssignment>& out, std::uint16_t robot) {
  for (const auto& a : out) {
    if (a.robot_id == robot) return &a;
  }
  return nullptr;
}

void expect_task(const std::vector<msg::TaskAssignment>& out, std::uint16_t robot, TaskKind kind, double x, double y) {
  const msg::TaskAssignment* a = for_robot(out, robot);
  ASSERT_NE(a, nullptr) << "no assignment for robot " << robot;
  EXPECT_EQ(a->kind, kind) << "robot " << robot;
  EXPECT_DOUBLE_EQ(a->target_x, x) << "robot " << robot;
  EXPECT_DOUBLE_EQ(a->target_y, y) << "robot " << robot;
}

TEST(IgrOverlap, FractionOfTheUnionHandComputed) {
  const Rect j{0, 0, 4, 4};  // area 16
  const std::vector<Rect> half{{2, 0, 6, 4}};
  EXPECT_DOUBLE_EQ(overlap_fraction(j, half), 0.5);  // 2 x 4 = 8 of 16
  // Two assigned regions overlapping each other: the union [0,3]x[0,4] = 12 of 16, not the
  // sum 8 + 8 = 16 (which would discount the frontier away entirely).
  const std::vector<Rect> two{{0, 0, 2, 4}, {1, 0, 3, 4}};
  EXPECT_DOUBLE_EQ(overlap_fraction(j, two), 0.75);
  EXPECT_DOUBLE_EQ(union_area(two), 12.0);
  const std::vector<Rect> far{{10, 10, 12, 12}};
  EXPECT_DOUBLE_EQ(overlap_fraction(j, far), 0.0);
  EXPECT_DOUBLE_EQ(overlap_fraction(j, {}), 0.0);
  // A degenerate (zero-area) IGR is covered when its centre is.
  EXPECT_DOUBLE_EQ(overlap_fraction(Rect{1, 1, 1, 1}, half), 0.0);
  EXPECT_DOUBLE_EQ(overlap_fraction(Rect{3, 1, 3, 1}, half), 1.0);
}

// Robot 1 takes A (u = 100). Robot 2's A2 overlaps A's IGR by half: u = (1 - 0.5)·90 - 5 = 40
// (undiscounted 85). Its B2 is far away with u = gain - 10. Bracketing B2's utility at 41 and
// 39 checks the discounted u_j = 40 within one cell.
TaskAllocator discount_case(bool coordinated, double b2_gain) {
  AllocatorConfig c = test_config();
  c.coordinated = coordinated;
  TaskAllocator a(c);
  a.on_bid(bid(1, {item(0, 2, 100, 0, {0, 0, 4, 4})}), 0);
  a.on_bid(bid(2, {item(4, 2, 90, 5, {2, 0, 6, 4}), item(12, 2, b2_gain, 10, {10, 0, 14, 4})}), 0);
  return a;
}

TEST(TaskAllocator, DiscountSendsCoordinatedRobotsToDifferentFrontiers) {
  TaskAllocator a = discount_case(true, 51);  // B2: u = 41 > 40
  const auto out = tick(a, sec(0.5));
  expect_task(out, 1, TaskKind::kExplore, 0, 2);
  expect_task(out, 2, TaskKind::kExplore, 12, 2);
}

TEST(TaskAllocator, DiscountedUtilityIsHalfTheGainMinusCost) {
  TaskAllocator a = discount_case(true, 49);  // B2: u = 39 < 40: the half-discounted A2 still wins
  const auto out = tick(a, sec(0.5));
  expect_task(out, 1, TaskKind::kExplore, 0, 2);
  expect_task(out, 2, TaskKind::kExplore, 4, 2);
}

TEST(TaskAllocator, UncoordinatedIgnoresTheOverlap) {
  TaskAllocator a = discount_case(false, 51);  // no discount: A2 u = 85 beats B2 u = 41
  const auto out = tick(a, sec(0.5));
  expect_task(out, 2, TaskKind::kExplore, 4, 2);
}

TEST(TaskAllocator, UncoordinatedSendsBothToTheSameBestItemCoordinatedDoesNot) {
  for (bool coordinated : {false, true}) {
    AllocatorConfig c = test_config();
    c.coordinated = coordinated;
    TaskAllocator a(c);
    a.on_bid(bid(1, {item(0, 0, 100, 0, {-2, -2, 2, 2})}), 0);
    a.on_bid(bid(2, {item(0, 0, 95, 0, {-2, -2, 2, 2}), item(10, 0, 50, 0, {8, -2, 12, 2})}), 0);
    const auto out = tick(a, sec(0.5));
    expect_task(out, 1, TaskKind::kExplore, 0, 0);
    if (coordinated) {
      expect_task(out, 2, TaskKind::kExplore, 10, 0);  // same region: d = 1, gain 0
    } else {
      expect_task(out, 2, TaskKind::kExplore, 0, 0);
    }
  }
}

// Robot 1 explores A (gain 100, IGR [0,2]²). Its new bid still offers A, and B elsewhere.
// With the ratio 0.85, A counts 100 / 0.85 = 117.6: B at 110 (it would win without
// hysteresis, or with the ratio applied the wrong way round: 85) does not take the robot
// away; B at 125 does.
TEST(TaskAllocator, HysteresisKeepsTheTaskWithinTheMargin) {
  for (double b_gain : {110.0, 125.0}) {
    AllocatorConfig c = test_config();
    c.cells_per_metre = 0;
    TaskAllocator a(c);
    a.on_bid(bid(1, {item(1, 1, 100, 0, {0, 0, 2, 2})}), 0);
    expect_task(tick(a, sec(0.5)), 1, TaskKind::kExplore, 1, 1);
    a.on_bid(bid(1, {item(1, 1, 100, 0, {0, 0, 2, 2}), item(10, 10, b_gain, 0, {9, 9, 11, 11})}), sec(1));
    const auto out = tick(a, sec(1.5));
    EXPECT_EQ(a.counters().rounds, 2u);
    if (b_gain < 100 / 0.85) {
      EXPECT_TRUE(out.empty()) << "kept task must not be re-sent";
      EXPECT_EQ(a.counters().tasks_kept, 1u);
      EXPECT_EQ(a.counters().switches, 0u);
      EXPECT_DOUBLE_EQ(a.task(1)->target.x(), 1);
    } else {
      expect_task(out, 1, TaskKind::kExplore, 10, 10);
      EXPECT_EQ(a.counters().switches, 1u);
    }
  }
}

TEST(TaskAllocator, ItemsAtOrBelowTheThresholdAreNeverAssigned) {
  TaskAllocator a(test_config());  // min_gain 20
  a.on_bid(bid(1, {item(0, 0, 20, 0, {-1, -1, 1, 1}), item(5, 0, 5, 0, {4, -1, 6, 1})}), 0);
  const auto out = tick(a, sec(0.5));
  expect_task(out, 1, TaskKind::kIdle, 0, 0);
  EXPECT_EQ(a.counters().explore_assigned, 0u);
  EXPECT_EQ(a.counters().idles, 1u);
}

TEST(TaskAllocator, ThresholdAppliesToTheDiscountedGain) {
  for (bool coordinated : {true, false}) {
    AllocatorConfig c = test_config();
    c.coordinated = coordinated;
    TaskAllocator a(c);
    a.on_bid(bid(1, {item(2, 2, 100, 0, {0, 0, 4, 4})}), 0);
    // 30 cells, 3/4 of its IGR inside robot 1's: 7.5 after the discount, below 20.
    a.on_bid(bid(2, {item(3, 2, 30, 0, {1, 0, 5, 4})}), 0);
    const auto out = tick(a, sec(0.5));
    expect_task(out, 2, coordinated ? TaskKind::kIdle : TaskKind::kExplore, coordinated ? 0 : 3, coordinated ? 0 : 2);
  }
}

// Robot 1 bids first and alone would take A. Robot 2's better bid on A arrives inside the
// wait: at bid_wait both are considered together and robot 1 gets B.
TEST(TaskAllocator, WaitsForOtherBidsThenAssignsThemTogether) {
  AllocatorConfig c = test_config();
  c.cells_per_metre = 0;
  TaskAllocator a(c);
  a.on_bid(bid(1, {item(0, 0, 100, 0, {0, 0, 4, 4}), item(20, 0, 60, 0, {18, -2, 22, 2})}), sec(1.0));
  EXPECT_TRUE(tick(a, sec(1.1)).empty());
  a.on_bid(bid(2, {item(0, 0, 150, 0, {0, 0, 4, 4})}), sec(1.3));
  EXPECT_TRUE(tick(a, sec(1.3)).empty());
  EXPECT_TRUE(tick(a, sec(1.5) - 1).empty());
  EXPECT_EQ(a.counters().rounds, 0u);
  const auto out = tick(a, sec(1.5));  // the first bid's time + bid_wait, not pushed back by the second
  EXPECT_EQ(a.counters().rounds, 1u);
  expect_task(out, 2, TaskKind::kExplore, 0, 0);
  expect_task(out, 1, TaskKind::kExplore, 20, 0);
  EXPECT_TRUE(tick(a, sec(2.0)).empty()) << "nothing changed, nothing sent";
}

// Two robots on A and B (robot 2's second choice: A is robot 1's region).
TaskAllocator two_robots_on_a_and_b(AllocatorConfig c) {
  TaskAllocator a(c);
  a.on_bid(bid(1, {item(0, 0, 100, 0, {-2, -2, 2, 2})}), 0);
  a.on_bid(bid(2, {item(0, 0, 90, 0, {-2, -2, 2, 2}), item(10, 0, 50, 0, {8, -2, 12, 2})}), 0);
  const auto out = tick(a, sec(0.5));
  expect_task(out, 1, TaskKind::kExplore, 0, 0);
  expect_task(out, 2, TaskKind::kExplore, 10, 0);
  return a;
}

TEST(TaskAllocator, UserVisitReassignsTheOthersAndReturnsToThePoolOnArrival) {
  TaskAllocator a = two_robots_on_a_and_b(test_config());
  ASSERT_TRUE(a.request_visit(1, Vec2(20, 20), sec(2)));
  auto out = tick(a, sec(2));
  expect_task(out, 1, TaskKind::kGoto, 20, 20);
  expect_task(out, 2, TaskKind::kExplore, 0, 0);  // covers robot 1's frontier (90 > 50 / 0.85)
  // Bids during the visit do not take robot 1 off it.
  a.on_bid(bid(1, {item(30, 30, 80, 0, {28, 28, 32, 32})}), sec(3));
  EXPECT_EQ(for_robot(tick(a, sec(3.5)), 1), nullptr);
  a.on_robot_pose(1, Vec2(20, 20.1), sec(4));
  EXPECT_TRUE(tick(a, sec(4)).empty());
  EXPECT_EQ(a.counters().visits_arrived, 1u);
  // Back in the pool: assigned from its next bid; robot 2 continues undisturbed.
  a.on_bid(bid(1, {item(30, 30, 80, 0, {28, 28, 32, 32})}), sec(5));
  out = tick(a, sec(5.5));
  ASSERT_EQ(out.size(), 1u);
  expect_task(out, 1, TaskKind::kExplore, 30, 30);
}

// The operator's stop (web view): the pool robots are told idle, no round runs and the end
// is not judged while paused, a visit still goes; the resume runs a full round at once.
TEST(TaskAllocator, PausedExplorationIdlesThePoolKeepsVisitsAndResumesWithAFullRound) {
  TaskAllocator a = two_robots_on_a_and_b(test_config());
  const auto view = a.task(1);
  ASSERT_TRUE(view);
  EXPECT_DOUBLE_EQ(view->igr.max_x, 2.0);  // the task's region, for the view
  EXPECT_DOUBLE_EQ(view->gain, 100.0);
  ASSERT_NE(a.latest_bid(2), nullptr);
  EXPECT_EQ(a.latest_bid(2)->n_items, 2);
  EXPECT_EQ(a.latest_bid(9), nullptr);

  a.set_paused(true, sec(1));
  EXPECT_TRUE(a.paused());
  auto out = tick(a, sec(1));
  expect_task(out, 1, TaskKind::kIdle, 0, 0);
  expect_task(out, 2, TaskKind::kIdle, 0, 0);
  EXPECT_FALSE(a.task(1)->active);
  EXPECT_EQ(a.task(1)->gain, 0.0);
  // New bids schedule no round while paused, and no bid with gain is not the end either.
  a.on_bid(bid(1, {item(5, 5, 100, 0, {3, 3, 7, 7})}), sec(2));
  a.on_bid(bid(2, {}), sec(2));
  bool ended = true;
  EXPECT_TRUE(tick(a, sec(3), &ended).empty());
  EXPECT_FALSE(ended);
  a.on_bid(bid(1, {}), sec(3.5));
  EXPECT_TRUE(tick(a, sec(4), &ended).empty());
  EXPECT_FALSE(ended) << "the end of exploration is not judged while paused";
  // A visit goes while paused.
  ASSERT_TRUE(a.request_visit(2, Vec2(20, 20), sec(5)));
  expect_task(tick(a, sec(5)), 2, TaskKind::kGoto, 20, 20);
  a.set_paused(true, sec(5.5));  // again: nothing changes
  EXPECT_TRUE(tick(a, sec(5.5)).empty());
  EXPECT_EQ(a.counters().pauses, 1u);

  // Resumed: a full round at once on the latest bids (robot 1's now offers a frontier).
  a.on_bid(bid(1, {item(5, 5, 100, 0, {3, 3, 7, 7})}), sec(6));
  a.set_paused(false, sec(6.1));
  out = tick(a, sec(6.1));
  expect_task(out, 1, TaskKind::kExplore, 5, 5);
  EXPECT_EQ(for_robot(out, 2), nullptr) << "robot 2's visit goes on";
}

// After reaching its frontier a robot waits for its next bid: the latest one was computed
// short of the target and still offers the frontier it now stands on.
TEST(TaskAllocator, ArrivalWaitsForTheRobotsNextBid) {
  TaskAllocator a = two_robots_on_a_and_b(test_config());
  a.on_robot_pose(1, Vec2(0.1, 0.1), sec(2));
  EXPECT_TRUE(tick(a, sec(2)).empty()) << "arrival itself sends nothing";
  EXPECT_EQ(a.counters().arrivals, 1u);
  a.on_bid(bid(2, {item(10, 0, 50, 0, {8, -2, 12, 2})}), sec(3));  // a round for robot 2's new bid
  EXPECT_TRUE(tick(a, sec(3.5)).empty()) << "robot 1 is not sent back to the frontier it reached";
  EXPECT_EQ(a.counters().rounds, 2u);
  a.on_bid(bid(1, {item(0, 6, 70, 0, {-2, 4, 2, 8})}), sec(4));
  const auto out = tick(a, sec(4.5));
  ASSERT_EQ(out.size(), 1u);
  expect_task(out, 1, TaskKind::kExplore, 0, 6);
}

TEST(TaskAllocator, UserVisitThatMakesNoProgressFailsBackToThePool) {
  AllocatorConfig c = test_config();
  c.no_progress_timeout = sec(10);
  TaskAllocator a(c);
  a.on_bid(bid(1, {item(5, 5, 100, 0, {4, 4, 6, 6})}), 0);
  ASSERT_TRUE(a.request_visit(1, Vec2(20, 20), 0));
  expect_task(tick(a, 0), 1, TaskKind::kGoto, 20, 20);
  a.on_robot_pose(1, Vec2(0, 0), sec(1));
  EXPECT_TRUE(tick(a, sec(11) - 1).empty());
  const auto out = tick(a, sec(11));
  EXPECT_EQ(a.counters().visits_failed, 1u);
  expect_task(out, 1, TaskKind::kExplore, 5, 5);
}

// One robot on A makes no progress: taken back, A barred for it for bar_duration, sent to B.
// While barred, a new bid preferring A leaves it on B; after the bar expires it switches.
TEST(TaskAllocator, NoProgressTakesTheTaskBackAndTheBarExpires) {
  AllocatorConfig c = test_config();
  c.cells_per_metre = 0;
  c.no_progress_timeout = sec(10);
  c.bar_duration = sec(30);
  TaskAllocator a(c);
  const auto both = bid(1, {item(10, 0, 100, 0, {9, -1, 11, 1}), item(0, 10, 60, 0, {-1, 9, 1, 11})});
  a.on_bid(both, 0);
  expect_task(tick(a, sec(0.5)), 1, TaskKind::kExplore, 10, 0);
  a.on_robot_pose(1, Vec2(0, 0), sec(1));
  a.on_robot_pose(1, Vec2(0.1, 0), sec(5));  // less than progress_step_m: not progress
  EXPECT_TRUE(tick(a, sec(11) - 1).empty());
  expect_task(tick(a, sec(11)), 1, TaskKind::kExplore, 0, 10);
  EXPECT_EQ(a.counters().timeouts, 1u);
  EXPECT_EQ(a.counters().bars_set, 1u);
  for (int k = 0; k < 6; ++k) {  // steady progress towards B, 0.5 m every 5 s, up to t = 37 s
    a.on_robot_pose(1, Vec2(0.1, 0.5 * (k + 1)), sec(12 + 5 * k));
    EXPECT_TRUE(tick(a, sec(12 + 5 * k)).empty());
  }
  a.on_bid(both, sec(38));  // A (100) would beat B (60 / 0.85 = 70.6), but A is barred until 41
  EXPECT_TRUE(tick(a, sec(38.5)).empty());
  EXPECT_EQ(a.counters().tasks_kept, 1u);
  EXPECT_EQ(a.counters().bars_expired, 0u);
  a.on_bid(both, sec(41));
  expect_task(tick(a, sec(41.5)), 1, TaskKind::kExplore, 10, 0);
  EXPECT_EQ(a.counters().bars_expired, 1u);
  EXPECT_EQ(a.counters().timeouts, 1u);
}

// Issue 15: a robot that reports itself stuck (RobotStatus.nav_state) has its task taken
// back at once, long before the no-progress monitor would: A barred for it, sent to B in
// the same tick. A report about another task (an old one, or repeated after the take-back)
// does nothing.
TEST(TaskAllocator, AStuckReportTakesTheTaskBackAtOnce) {
  AllocatorConfig c = test_config();
  c.cells_per_metre = 0;
  c.no_progress_timeout = sec(20);
  TaskAllocator a(c);
  a.on_bid(bid(1, {item(10, 0, 100, 0, {9, -1, 11, 1}), item(0, 10, 60, 0, {-1, 9, 1, 11})}), 0);
  const auto first = tick(a, sec(0.5));
  expect_task(first, 1, TaskKind::kExplore, 10, 0);
  const std::uint32_t on_a = for_robot(first, 1)->task_id;
  a.on_robot_pose(1, Vec2(0, 0), sec(1));
  EXPECT_FALSE(a.on_stuck(1, on_a + 7, sec(6))) << "not its current task";
  EXPECT_FALSE(a.on_stuck(2, on_a, sec(6))) << "a robot the executive does not know";
  EXPECT_TRUE(tick(a, sec(6)).empty());
  EXPECT_TRUE(a.on_stuck(1, on_a, sec(6)));
  expect_task(tick(a, sec(6)), 1, TaskKind::kExplore, 0, 10);  // 14 s before the monitor would
  EXPECT_EQ(a.counters().stuck_reports, 1u);
  EXPECT_EQ(a.counters().timeouts, 0u);
  EXPECT_EQ(a.counters().bars_set, 1u);
  EXPECT_FALSE(a.on_stuck(1, on_a, sec(7))) << "the same report again: already taken back";
  EXPECT_EQ(a.counters().stuck_reports, 1u);
}

TEST(TaskAllocator, LinkLossFreesTheTask) {
  TaskAllocator a = two_robots_on_a_and_b(test_config());
  a.on_link(1, false, sec(2));
  auto out = tick(a, sec(2));
  EXPECT_EQ(for_robot(out, 1), nullptr) << "nothing is sent to a lost robot";
  expect_task(out, 2, TaskKind::kExplore, 0, 0);
  EXPECT_EQ(a.counters().tasks_released, 1u);
  EXPECT_FALSE(a.request_visit(1, Vec2(3, 3), sec(2.5)));
  a.on_link(1, true, sec(3));
  out = tick(a, sec(3));
  ASSERT_EQ(out.size(), 1u);
  expect_task(out, 1, TaskKind::kIdle, 0, 0);  // its old frontier is robot 2's now
}

TEST(TaskAllocator, EndOfExplorationReportedOnceWhenNoBidHasGain) {
  AllocatorConfig c = test_config();
  c.home[2] = Vec2(-1, -1);
  TaskAllocator a(c);
  int reports = 0;
  bool ended = false;
  a.on_bid(bid(1, {item(5, 0, 100, 0, {4, -1, 6, 1})}), 0);
  a.on_bid(bid(2, {item(9, 9, 10, 0, {8, 8, 10, 10})}), 0);
  tick(a, sec(0.5), &ended);
  reports += ended;
  EXPECT_FALSE(a.explored()) << "robot 1 is still on a task";
  a.on_robot_pose(1, Vec2(5, 0.1), sec(3));
  tick(a, sec(3), &ended);
  reports += ended;
  EXPECT_FALSE(a.explored()) << "robot 1 has not bid since it arrived";
  a.on_bid(bid(1, {item(6, 0, 20, 0, {5, -1, 7, 1})}), sec(4));  // gain 20: not above min_gain
  std::vector<msg::TaskAssignment> out;
  for (Nanos t = sec(4); t <= sec(10); t += sec(0.25)) {
    const auto o = tick(a, t, &ended);
    out.insert(out.end(), o.begin(), o.end());
    reports += ended;
    if (t == sec(6)) a.on_bid(bid(2, {}), t);  // more bids without gain change nothing
    if (t == sec(8)) a.on_robot_pose(2, Vec2(-1, -1), t);  // home: every robot idle, still one report
  }
  EXPECT_TRUE(a.explored());
  EXPECT_EQ(reports, 1);
  EXPECT_EQ(a.counters().explored_reports, 1u);
  expect_task(out, 1, TaskKind::kIdle, 0, 0);
  expect_task(out, 2, TaskKind::kGoto, -1, -1);  // configured home
  EXPECT_EQ(out.size(), 2u);
}

// At start-up a robot's map may hold no clear cell yet (every cell near p = 0.5), so its
// first bids are empty: that is not an explored world. The end waits until some bid has
// shown a frontier, then follows the usual rule.
TEST(TaskAllocator, NoEndBeforeAnyBidHasShownAFrontier) {
  TaskAllocator a(test_config());
  bool ended = false;
  for (Nanos t = 0; t <= sec(30); t += sec(0.25)) {
    if (t % sec(2) == 0) {
      a.on_bid(bid(1, {}), t);
      a.on_bid(bid(2, {}), t);
    }
    tick(a, t, &ended);
    ASSERT_FALSE(ended) << "at " << nanos_to_seconds(t) << " s, before any frontier was bid";
  }
  EXPECT_FALSE(a.explored());
  EXPECT_FALSE(a.frontier_seen());
  // A frontier appears, is reached, and the next bids hold none: now the world is explored.
  a.on_bid(bid(1, {item(5, 0, 100, 0, {4, -1, 6, 1})}), sec(31));
  tick(a, sec(31.5), &ended);
  EXPECT_FALSE(a.explored());
  a.on_robot_pose(1, Vec2(5, 0.1), sec(33));
  tick(a, sec(33), &ended);
  a.on_bid(bid(1, {}), sec(34));
  a.on_bid(bid(2, {}), sec(34));
  int reports = 0;
  for (Nanos t = sec(34); t <= sec(40); t += sec(0.25)) {
    tick(a, t, &ended);
    reports += ended;
  }
  EXPECT_TRUE(a.explored());
  EXPECT_EQ(reports, 1);
}

// A frontier without gain (an item at or below min_gain) is a frontier shown: the map
// holds clear cells next to unknown ones. The end then follows the usual rule at once.
TEST(TaskAllocator, AFrontierWithoutGainAlsoLetsExplorationEnd) {
  TaskAllocator a(test_config());
  bool ended = false;
  int reports = 0;
  a.on_bid(bid(1, {item(3, 0, 20, 0, {2, -1, 4, 1})}), 0);  // gain 20: not above min_gain
  a.on_bid(bid(2, {}), 0);
  EXPECT_TRUE(a.frontier_seen());
  for (Nanos t = 0; t <= sec(2); t += sec(0.25)) {
    tick(a, t, &ended);
    reports += ended;
  }
  EXPECT_TRUE(a.explored());
  EXPECT_EQ(reports, 1);
}

msg::UnreachableCluster cluster(double min_x, double min_y, double max_x, double max_y, std::uint32_t cells,
                                 msg::UnreachableKind kind) {
  return {(min_x + max_x) / 2, (min_y + max_y) / 2, min_x, min_y, max_x, max_y, cells, kind};
}

TEST(TaskAllocator, EndOfExplorationListsUnreachableFrontiersMergedAcrossRobots) {
  TaskAllocator a(test_config());
  using K = msg::UnreachableKind;
  // Robot 1 sees the door at x = 4 as too narrow and a window patch; robot 2 sees the same
  // door from the other side of the room as disconnected (its box overlaps robot 1's), and
  // a patch of its own far away. A later bid of robot 1 replaces its earlier clusters.
  msg::Bid b1 = bid(1, {});
  b1.n_unreachable = 1;
  b1.unreachable[0] = cluster(-30, -30, -29, -29, 3, K::kDisconnected);  // replaced below
  a.on_bid(b1, 0);
  b1.n_unreachable = 2;
  b1.unreachable[0] = cluster(4.0, 1.0, 4.3, 1.6, 4, K::kTooNarrow);
  b1.unreachable[1] = cluster(10, 0, 11, 2, 9, K::kDisconnected);
  msg::Bid b2 = bid(2, {});
  b2.n_unreachable = 2;
  b2.unreachable[0] = cluster(4.15, 1.45, 4.6, 2.0, 6, K::kDisconnected);
  b2.unreachable[1] = cluster(-5, -5, -4.5, -4, 2, K::kDisconnected);
  b2.unreachable_dropped = 3;
  a.on_bid(b1, 0);
  a.on_bid(b2, 0);
  bool ended = false;
  tick(a, sec(0.5), &ended);
  ASSERT_TRUE(ended) << "no item has gain: only unreachable frontiers are left";
  const std::vector<UnreachableArea> left = a.unreachable();
  ASSERT_EQ(left.size(), 3u);
  // Largest first: the window patch (9), the door (6, the larger report), the far patch.
  EXPECT_EQ(left[0].cells, 9u);
  EXPECT_EQ(left[0].robots, (std::vector<std::uint16_t>{1}));
  const UnreachableArea& door = left[1];
  EXPECT_EQ(door.cells, 6u);
  EXPECT_EQ(door.kind, K::kTooNarrow) << "robot 1 found a way there too narrow for it";
  EXPECT_EQ(door.robots, (std::vector<std::uint16_t>{1, 2}));
  EXPECT_DOUBLE_EQ(door.min_x, 4.0);
  EXPECT_DOUBLE_EQ(door.min_y, 1.0);
  EXPECT_DOUBLE_EQ(door.max_x, 4.6);
  EXPECT_DOUBLE_EQ(door.max_y, 2.0);
  EXPECT_NEAR(door.x, (4.15 * 4 + 4.375 * 6) / 10, 1e-12);  // centroids weighted by cells
  EXPECT_NEAR(door.y, (1.3 * 4 + 1.725 * 6) / 10, 1e-12);
  EXPECT_EQ(left[2].robots, (std::vector<std::uint16_t>{2}));
  EXPECT_DOUBLE_EQ(left[2].x, -4.75);
  EXPECT_EQ(a.unreachable_dropped(), 3u);
  EXPECT_EQ(describe(door), "too narrow at (4.29, 1.56) m, box [4.00, 4.60] x [1.00, 2.00] m, 6 cells, robots 1 2");
  // frontiers.json: valid JSON carrying every area.
  const nlohmann::json j = nlohmann::json::parse(unreachable_json(left, a.unreachable_dropped()));
  EXPECT_EQ(j["count"], 3);
  EXPECT_EQ(j["dropped"], 3);
  ASSERT_EQ(j["unreachable"].size(), 3u);
  EXPECT_EQ(j["unreachable"][1]["kind"], "too narrow");
  EXPECT_EQ(j["unreachable"][1]["robots"], nlohmann::json({1, 2}));
  EXPECT_DOUBLE_EQ(j["unreachable"][1]["max_x"].get<double>(), 4.6);
  EXPECT_EQ(j["unreachable"][2]["kind"], "disconnected");
  EXPECT_EQ(j["unreachable"][2]["cells"], 2);
  EXPECT_EQ(nlohmann::json::parse(unreachable_json({}, 0))["count"], 0);

  // A third robot's cluster bridging the door and the window patch merges all three.
  msg::Bid b3 = bid(3, {});
  b3.n_unreachable = 1;
  b3.unreachable[0] = cluster(4.5, 1.5, 10.5, 1.7, 2, K::kDisconnected);
  a.on_bid(b3, sec(1));
  EXPECT_EQ(a.unreachable().size(), 2u);
}

// A frontier that survives two robots' approaches (a pocket too narrow to enter, the
// unseen inside of a block) is given up: not assigned again, not counted by the end of
// exploration, which then ends; offered again with more than twice its gain, it is back. With give_up_attempts = 0 the same robot is sent back to
// it for ever. One attempt per task, however many poses fall within look_radius_m.
TEST(TaskAllocator, AFrontierStillThereAfterTwoApproachesIsGivenUpAndExplorationEnds) {
  auto run = [](std::uint32_t give_up_attempts, TaskAllocator* out_allocator) {
    AllocatorConfig c = test_config();
    c.cells_per_metre = 0;
    c.give_up_attempts = give_up_attempts;
    TaskAllocator a(c);
    std::uint32_t sent_to_a = 0;
    double t = 0;
    for (int visit = 0; visit < 4; ++visit) {
      // The robot's bid: the same frontier, its kept cell shifting by up to 0.4 m.
      const double x = 10 + 0.1 * visit, y = 0.1 * visit;
      a.on_bid(bid(1, {item(x, y, 100, 5, {9, -1, 13, 3})}), sec(t));
      const auto out = tick(a, sec(t + 0.5));
      if (const auto* task = for_robot(out, 1); task != nullptr && task->kind == TaskKind::kExplore) ++sent_to_a;
      for (double d : {3.0, 0.9, 0.6, 0.2}) a.on_robot_pose(1, Vec2(x - d, y), sec(t + 1 + 3 - d));  // approach, arrive
      tick(a, sec(t + 4));
      t += 5;
    }
    a.on_bid(bid(1, {item(10.3, 0.3, 100, 0, {9, -1, 13, 3})}), sec(t));
    for (double u = t; u <= t + 2; u += 0.25) tick(a, sec(u));
    *out_allocator = a;
    return sent_to_a;
  };
  TaskAllocator a(test_config());
  EXPECT_EQ(run(2, &a), 2u) << "sent to it twice, then never again";
  EXPECT_EQ(a.counters().attempts, 2u) << "one attempt per task, not per pose";
  EXPECT_EQ(a.counters().frontiers_given_up, 1u);
  ASSERT_EQ(a.given_up().size(), 1u);
  EXPECT_DOUBLE_EQ(a.given_up()[0].x(), 10.0);
  EXPECT_TRUE(a.explored()) << "a given-up frontier does not hold the end of exploration";
  // Not forever: offered again with more than twice its gain (a door opened), it is back.
  a.on_bid(bid(1, {item(10.2, 0.2, 200, 0, {9, -1, 13, 3})}), sec(100));
  EXPECT_EQ(a.counters().given_up_released, 0u) << "200 is not more than twice 100";
  a.on_bid(bid(1, {item(10.2, 0.2, 201, 0, {9, -1, 13, 3})}), sec(101));
  EXPECT_EQ(a.counters().given_up_released, 1u);
  EXPECT_FALSE(a.explored()) << "exploration resumes";
  expect_task(tick(a, sec(101.5)), 1, TaskKind::kExplore, 10.2, 0.2);
  EXPECT_EQ(run(0, &a), 4u) << "without the rule it is assigned on every bid";
  EXPECT_FALSE(a.explored());
  EXPECT_EQ(a.counters().frontiers_given_up, 0u);
}

// A task taken back (stuck report or no progress) is an attempt at its frontier too: after
// two take-backs the frontier is not assigned again, even once its bar has expired.
TEST(TaskAllocator, TwoTakeBacksAtAFrontierGiveItUp) {
  AllocatorConfig c = test_config();
  c.cells_per_metre = 0;
  c.bar_duration = sec(10);
  TaskAllocator a(c);
  const auto both = bid(1, {item(10, 0, 100, 0, {9, -1, 11, 1}), item(0, 10, 60, 0, {-1, 9, 1, 11})});
  a.on_robot_pose(1, Vec2(0, 0), 0);
  a.on_bid(both, 0);
  auto out = tick(a, sec(0.5));
  expect_task(out, 1, TaskKind::kExplore, 10, 0);
  ASSERT_TRUE(a.on_stuck(1, for_robot(out, 1)->task_id, sec(1)));
  expect_task(tick(a, sec(1)), 1, TaskKind::kExplore, 0, 10);
  a.on_bid(both, sec(12));  // the bar expired at 11 s: back to A
  out = tick(a, sec(12.5));
  expect_task(out, 1, TaskKind::kExplore, 10, 0);
  ASSERT_TRUE(a.on_stuck(1, for_robot(out, 1)->task_id, sec(13)));
  EXPECT_EQ(a.counters().frontiers_given_up, 1u);
  expect_task(tick(a, sec(13)), 1, TaskKind::kExplore, 0, 10);
  a.on_bid(both, sec(30));  // long after the bar: A stays given up, B is kept
  EXPECT_TRUE(tick(a, sec(30.5)).empty());
  EXPECT_EQ(a.counters().attempts, 2u);
  EXPECT_EQ(a.task(1)->target.y(), 10.0);
}

TEST(TaskAllocator, ConfigErrorsNameTheParameter) {
  const auto message = [](AllocatorConfig c) -> std::string {
    try {
      TaskAllocator a(c);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  AllocatorConfig c = test_config();
  c.hysteresis_ratio = 0;
  EXPECT_NE(message(c).find("hysteresis_ratio"), std::string::npos);
  c.hysteresis_ratio = 1.2;
  EXPECT_NE(message(c).find("hysteresis_ratio"), std::string::npos);
  c = test_config();
  c.cells_per_metre = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(c).find("cells_per_metre"), std::string::npos);
  c = test_config();
  c.bid_wait = -1;
  EXPECT_NE(message(c).find("bid_wait"), std::string::npos);
  c = test_config();
  c.no_progress_timeout = 0;
  EXPECT_NE(message(c).find("no_progress_timeout"), std::string::npos);
  c = test_config();
  c.look_radius_m = c.arrival_radius_m / 2;  // an arrival must be an attempt
  EXPECT_NE(message(c).find("look_radius_m"), std::string::npos);
  EXPECT_EQ(message(test_config()), "");
}

TEST(TaskAllocator, MalformedBidsAreRefusedAndCounted) {
  TaskAllocator a(test_config());
  msg::Bid too_many = bid(1, {});
  too_many.n_items = msg::kMaxBids + 1;
  EXPECT_FALSE(a.on_bid(too_many, 0));
  EXPECT_FALSE(a.on_bid(bid(1, {item(0, 0, std::nan(""), 0, {0, 0, 1, 1})}), 0));
  EXPECT_FALSE(a.on_bid(bid(1, {item(0, 0, 50, 0, {1, 0, 0, 1})}), 0));  // inverted IGR
  EXPECT_FALSE(a.on_bid(bid(0, {}), 0));
  EXPECT_FALSE(a.on_bid(bid(1, {item(2e4, 0, 50, 0, {0, 0, 1, 1})}), 0));     // finite, but 20 km away
  EXPECT_FALSE(a.on_bid(bid(1, {item(0, 0, 50, 0, {-1e300, 0, 1, 1})}), 0));  // an IGR as wide as the world
  EXPECT_EQ(a.counters().bids_rejected, 6u);
  EXPECT_TRUE(tick(a, sec(1)).empty()) << "a refused bid schedules nothing";
}

TEST(TaskAllocator, BidsWithMalformedUnreachableClustersAreRefused) {
  TaskAllocator a(test_config());
  const auto with_cluster = [](msg::UnreachableCluster u, std::uint16_t n = 1) {
    msg::Bid b = bid(1, {});
    b.n_unreachable = n;
    b.unreachable[0] = u;
    return b;
  };
  const msg::UnreachableCluster good{1.5, 1.5, 1, 1, 2, 2, 3, msg::UnreachableKind::kTooNarrow};
  EXPECT_TRUE(a.on_bid(with_cluster(good), 0));
  EXPECT_FALSE(a.on_bid(with_cluster(good, msg::kMaxUnreachable + 1), 0));
  msg::UnreachableCluster bad = good;
  bad.y = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.max_x = std::nan("");
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.min_y = 3;  // inverted box
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.x = 5;  // centroid outside its box
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.cells = 0;
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.kind = static_cast<msg::UnreachableKind>(7);
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  bad = good;
  bad.min_x = -1e300;  // finite but absurd: would merge every area and overflow the picture
  EXPECT_FALSE(a.on_bid(with_cluster(bad), 0));
  EXPECT_EQ(a.counters().bids_rejected, 8u);
  EXPECT_EQ(a.counters().bids_received, 1u);
  EXPECT_EQ(a.unreachable().size(), 1u) << "only the good bid's cluster is held";
}

}  // namespace
}  // namespace cairn::explore
