// The exploration executive's DDS edge (basestation/explore_node.hpp), on loopback in its
// own domain: bids written as robots write them reach the allocator only from robots the
// fusion has localised; the coordinated assignment comes back on TaskAssignment to each
// robot; a robot the fleet calls lost gives its task back. The allocator's own rules are
// task_allocator_test's.
#include "basestation/explore_node.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <future>
#include <limits>
#include <map>

#include "common/dds/convert.hpp"
#include "common/dds/profile.hpp"
#include "basestation/visit_request.hpp"

namespace cairn::base {
namespace {

constexpr std::uint32_t kDomain = 114;  // this test's own domain

FusionConfig two_robots() {
  FusionConfig c;
  RobotPrior p;
  p.known = true;
  p.sigma = Vec3(0.05, 0.05, 0.01);
  p.pose = {0, 0, 0};
  c.robots[1] = p;
  p.pose = {0, 4, 0};
  c.robots[2] = p;
  return c;
}

void localise(Fusion* f, std::uint16_t robot) {
  msg::OdometryIncrement o;
  o.robot_id = robot;
  o.seq = 1;
  o.t0 = 0;
  o.t1 = 10 * kNanosPerMilli;
  o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
  o.boot_epoch = 7;
  ASSERT_EQ(f->on_odometry(o), Fusion::Result::kApplied);
}

msg::BidItem item(double x, double y, double gain, double cost, double half) {
  return {x, y, gain, cost, x - half, y - half, x + half, y + half};
}

// The base's exploration node in its own DDS domain, with robots 1 and 2 localised by its
// fusion and alive in its fleet table, and the robots' participant with a Bid writer
// matched to it.
struct Base {
  explicit Base(std::uint32_t domain)
      : pp(dds::loopback_profile(domain)),
        fusion(two_robots()),
        fleet(3 * kNanosPerSecond, nullptr, FleetAdmission{{1, 2}, 8, {}}),
        node(pp, config()),
        robots(dds::loopback_profile(domain)),
        bid_topic(robots),
        bids(robots, bid_topic, dds::state_qos(1), {1, 2, 9}) {
    localise(&fusion, 1);
    localise(&fusion, 2);
    for (std::uint16_t id : {std::uint16_t{1}, std::uint16_t{2}}) fleet.on_status(id, "r", "running", 1, clock.now());
  }
  static explore::AllocatorConfig config() {
    explore::AllocatorConfig cfg;
    cfg.bid_wait = 100 * kNanosPerMilli;
    return cfg;
  }
  void write(const msg::Bid& b) {
    cairn_Bid d{};
    dds::to_dds(b, &d);
    ASSERT_TRUE(bids.write(d));
  }
  MonotonicClock& clock = MonotonicClock::instance();
  dds::Participant pp;
  Fusion fusion;
  Fleet fleet;
  ExploreNode node;
  dds::Participant robots;
  dds::Topic<cairn_Bid> bid_topic;
  dds::RobotWriters<cairn_Bid> bids;  // robots 1, 2 and 9, each in its partition
};

// Both robots' best item is the same frontier A (robot 1 is nearer); robot 2's second is
// B, elsewhere. Coordinated: 1 takes A, 2's A is discounted by the whole overlap, so 2
// takes B.
std::pair<msg::Bid, msg::Bid> bids_sharing_a_frontier() {
  msg::Bid b1, b2;
  b1.robot_id = 1;
  b1.seq = 1;
  b1.n_items = 1;
  b1.items[0] = item(6, 2, 300, 6, 2);
  b2.robot_id = 2;
  b2.seq = 1;
  b2.n_items = 2;
  b2.items[0] = item(6, 2, 300, 6.5, 2);
  b2.items[1] = item(-6, 6, 150, 6, 2);
  return {b1, b2};
}

TEST(ExploreNode, BidsFromLocalisedRobotsComeBackAsCoordinatedTasks) {
  Base b(kDomain);
  auto& clock = b.clock;
  auto& robots = b.robots;
  b.fleet.on_status(9, "r", "running", 1, clock.now());
  ASSERT_TRUE(b.bids.wait_for_readers(1, 5 * kNanosPerSecond));
  // Robot 9 is not in the fusion: its bid must not count.
  const auto [b1, b2] = bids_sharing_a_frontier();
  msg::Bid b9;
  b9.robot_id = 9;
  b9.seq = 1;
  b9.n_items = 1;
  b9.items[0] = item(1, 1, 1000, 1, 1);
  for (const msg::Bid& bid : {b1, b2, b9}) b.write(bid);

  dds::Topic<cairn_TaskAssignment> task_topic(robots);
  dds::Reader<cairn_TaskAssignment> tasks(robots, task_topic, dds::latched_qos());
  std::map<std::uint16_t, msg::TaskAssignment> got;
  const Nanos end = clock.now() + 5 * kNanosPerSecond;
  while (got.size() < 2 && clock.now() < end) {
    b.node.poll(clock.now(), b.fusion, b.fleet);
    tasks.take([&](const cairn_TaskAssignment& d, const dds_sample_info_t&) {
      msg::TaskAssignment t;
      ASSERT_TRUE(dds::from_dds(d, &t));
      got[t.robot_id] = t;
    });
    usleep(5000);
  }
  ASSERT_EQ(got.size(), 2u) << b.node.summary();
  EXPECT_EQ(got.count(9), 0u);
  EXPECT_EQ(got[1].kind, msg::TaskKind::kExplore);
  EXPECT_DOUBLE_EQ(got[1].target_x, 6);
  EXPECT_DOUBLE_EQ(got[1].target_y, 2);
  EXPECT_EQ(got[2].kind, msg::TaskKind::kExplore);
  EXPECT_DOUBLE_EQ(got[2].target_x, -6);
  EXPECT_DOUBLE_EQ(got[2].target_y, 6);
  EXPECT_EQ(b.node.counters().bids_taken, 2u);
  EXPECT_EQ(b.node.counters().bids_unlocalised, 1u);
  EXPECT_EQ(b.node.counters().assignments_written, 2u);
  EXPECT_NE(b.node.summary().find("bids 2 (unlocalised 1"), std::string::npos) << b.node.summary();

  // Robot 2 falls silent: the fleet calls it lost and the allocator takes its task back.
  b.fleet.on_lost(2, clock.now());
  b.node.poll(clock.now(), b.fusion, b.fleet);
  EXPECT_EQ(b.node.allocator().counters().link_losses, 1u);
  const auto t2 = b.node.allocator().task(2);
  ASSERT_TRUE(t2.has_value());
  EXPECT_FALSE(t2->active);
}

// Both robots bid, with nothing left to gain: poll() says exploration is complete once,
// in the poll where it happens (cairn-base then reports the mapped area and saves the map).
TEST(ExploreNode, PollReportsTheEndOfExplorationOnce) {
  Base b(kDomain + 1);
  auto& clock = b.clock;
  const explore::AllocatorConfig cfg = Base::config();
  ASSERT_TRUE(b.bids.wait_for_readers(1, 5 * kNanosPerSecond));
  for (std::uint16_t id : {std::uint16_t{1}, std::uint16_t{2}}) {
    msg::Bid nothing;
    nothing.robot_id = id;
    nothing.seq = 1;
    nothing.n_items = 1;
    nothing.items[0] = item(3, id, cfg.min_gain, 1, 1);  // gain not above the threshold
    b.write(nothing);
  }
  // The bids arrive on the wall clock; after that the node runs on simulated time: 2 s in
  // 50 ms polls, well past the 100 ms wait for bids.
  int completions = 0;
  const Nanos end = clock.now() + 5 * kNanosPerSecond;
  Nanos now = clock.now();
  while (b.node.counters().bids_taken < 2 && (now = clock.now()) < end) {
    completions += b.node.poll(now, b.fusion, b.fleet) ? 1 : 0;
    usleep(5000);
  }
  ASSERT_EQ(b.node.counters().bids_taken, 2u) << b.node.summary();
  for (int k = 1; k <= 40; ++k) completions += b.node.poll(now + k * 50 * kNanosPerMilli, b.fusion, b.fleet) ? 1 : 0;
  EXPECT_TRUE(b.node.allocator().explored()) << b.node.summary();
  EXPECT_EQ(completions, 1);
}

// "Robot 1, visit (2.5, -1.5)" from the operator's tool while both robots explore: the
// tool's request reaches the executive, robot 1 gets a GOTO task there (the tool sees it
// and says so), and robot 2 takes over the frontier robot 1 held. Requests the executive
// must refuse (a robot it has not localised, a NaN or far target) change nothing and are
// counted; with no base the tool says so.
TEST(ExploreNode, VisitRequestSendsTheRobotThereAndTheOthersCoverForIt) {
  Base b(kDomain + 2);
  auto& clock = b.clock;
  ASSERT_TRUE(b.bids.wait_for_readers(1, 5 * kNanosPerSecond));
  const auto [b1, b2] = bids_sharing_a_frontier();  // 1 takes A (6, 2), 2 takes B (-6, 6)
  b.write(b1);
  b.write(b2);
  auto task_of = [&](std::uint16_t id) { return b.node.allocator().task(id); };
  const Nanos end = clock.now() + 5 * kNanosPerSecond;
  while (!(task_of(1) && task_of(1)->kind == msg::TaskKind::kExplore && task_of(2) &&
           task_of(2)->kind == msg::TaskKind::kExplore) &&
         clock.now() < end) {
    b.node.poll(clock.now(), b.fusion, b.fleet);
    usleep(5000);
  }
  ASSERT_TRUE(task_of(2) && task_of(2)->target.isApprox(Vec2(-6, 6))) << b.node.summary();

  // The operator's tool, on its own participant, while the base keeps polling.
  dds::Participant tool(dds::loopback_profile(kDomain + 2));
  auto poll_while = [&](std::future<VisitResult>& f) {
    while (f.wait_for(std::chrono::milliseconds(5)) != std::future_status::ready) b.node.poll(clock.now(), b.fusion, b.fleet);
    return f.get();
  };
  VisitRequestOptions o;
  o.robot = 1;
  o.target = Vec2(2.5, -1.5);
  o.issued_by = "explore_node_test";
  auto visit = std::async(std::launch::async, [&] { return request_visit(tool, o); });
  const VisitResult r = poll_while(visit);
  ASSERT_TRUE(r.ok()) << r.message << "; " << b.node.summary();
  EXPECT_EQ(r.sent, 1);
  EXPECT_NE(r.message.find("assigned as task"), std::string::npos) << r.message;
  ASSERT_TRUE(task_of(1));
  EXPECT_EQ(task_of(1)->kind, msg::TaskKind::kGoto);
  EXPECT_EQ(task_of(1)->task_id, r.task_id);
  EXPECT_TRUE(task_of(1)->target.isApprox(Vec2(2.5, -1.5)));
  EXPECT_EQ(b.node.counters().visits_taken, 1u);
  EXPECT_EQ(b.node.allocator().counters().visits_requested, 1u);
  // Robot 2 covers for robot 1: the next round (after the wait for bids) gives it A.
  const Nanos cover_end = clock.now() + 5 * kNanosPerSecond;
  while (!task_of(2)->target.isApprox(Vec2(6, 2)) && clock.now() < cover_end) {
    b.node.poll(clock.now(), b.fusion, b.fleet);
    usleep(5000);
  }
  EXPECT_TRUE(task_of(2)->target.isApprox(Vec2(6, 2))) << task_of(2)->target.transpose() << "; " << b.node.summary();
  EXPECT_EQ(task_of(1)->kind, msg::TaskKind::kGoto);  // still on its visit

  // The same request again: confirmed only by the new task, not by the robot's current
  // (latched) task to the same place.
  auto again = std::async(std::launch::async, [&] { return request_visit(tool, o); });
  const VisitResult r2 = poll_while(again);
  ASSERT_TRUE(r2.ok()) << r2.message;
  EXPECT_GT(r2.task_id, r.task_id);
  EXPECT_EQ(task_of(1)->task_id, r2.task_id);
  EXPECT_EQ(b.node.counters().visits_taken, 2u);

  // Refused: robot 9 is not localised (the tool reports no confirmation); NaN and far
  // targets written raw. None changes robot 1's visit.
  o.robot = 9;
  o.timeout = 1500 * kNanosPerMilli;
  o.confirm_wait = 500 * kNanosPerMilli;
  auto refused = std::async(std::launch::async, [&] { return request_visit(tool, o); });
  const VisitResult rr = poll_while(refused);
  EXPECT_EQ(rr.outcome, VisitOutcome::kUnconfirmed) << rr.message;
  EXPECT_GE(rr.sent, 2);  // it retried
  dds::Topic<cairn_VisitRequest> visit_topic(tool);
  dds::Writer<cairn_VisitRequest> raw(tool, visit_topic, dds::state_qos(1));
  ASSERT_TRUE(raw.wait_for_readers(1, 5 * kNanosPerSecond));
  const std::uint64_t refused_before = b.node.counters().visits_refused;
  EXPECT_EQ(refused_before, static_cast<std::uint64_t>(rr.sent));
  // One at a time: the reader keeps the latest request per robot (a newer one replaces an
  // older one not yet taken).
  std::uint64_t expected = refused_before;
  for (const Vec2& target : {Vec2(std::nan(""), 1.0), Vec2(1.0, std::numeric_limits<double>::infinity()), Vec2(2e4, 0.0)}) {
    cairn_VisitRequest d{};
    d.robot_id = 2;
    d.seq = 1;
    d.x = target.x();
    d.y = target.y();
    ASSERT_TRUE(raw.write(d));
    ++expected;
    const Nanos refuse_end = clock.now() + 5 * kNanosPerSecond;
    while (b.node.counters().visits_refused < expected && clock.now() < refuse_end) {
      b.node.poll(clock.now(), b.fusion, b.fleet);
      usleep(5000);
    }
  }
  EXPECT_EQ(b.node.counters().visits_refused, refused_before + 3) << b.node.summary();
  EXPECT_EQ(b.node.counters().visits_taken, 2u);
  EXPECT_TRUE(task_of(2)->target.isApprox(Vec2(6, 2)));
  EXPECT_NE(b.node.summary().find("visits 2 (refused " + std::to_string(refused_before + 3) + ")"), std::string::npos)
      << b.node.summary();
}

TEST(ExploreNode, VisitToolReportsWhenNoBaseListens) {
  dds::Participant tool(dds::loopback_profile(kDomain + 3));  // no base on this domain
  VisitRequestOptions o;
  o.robot = 1;
  o.timeout = 500 * kNanosPerMilli;
  const VisitResult r = request_visit(tool, o);
  EXPECT_EQ(r.outcome, VisitOutcome::kNoBase);
  EXPECT_EQ(r.sent, 0);
  EXPECT_NE(r.message.find("no base station reads visit requests"), std::string::npos) << r.message;
}

TEST(ExploreNode, VisitChecksRefuseNonFiniteFarAndUnlocalised) {
  msg::VisitRequest v;
  v.x = 3;
  v.y = 4;
  EXPECT_EQ(check_visit(v, true), VisitVerdict::kAccepted);
  EXPECT_EQ(check_visit(v, false), VisitVerdict::kNotLocalised);
  v.x = kMaxVisitDistanceM;  // hypot > limit
  EXPECT_EQ(check_visit(v, true), VisitVerdict::kTooFar);
  v.x = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(check_visit(v, true), VisitVerdict::kNotFinite);
  v.x = 0;
  v.y = std::nan("");
  EXPECT_EQ(check_visit(v, true), VisitVerdict::kNotFinite);
}

// A target no robot could arrive at (no clear cell within the allocator's arrival radius:
// paths run over clear cells) is refused at once, with the reason, instead of being
// assigned and failing when the robot reports itself stuck. A target on an obstacle or
// unknown cell with a clear cell within the radius is accepted: the planner goes to the
// nearest reachable clear cell, and arriving there is arriving.
TEST(ExploreNode, VisitChecksRefuseATargetWithNoClearCellWithinTheArrivalRadius) {
  ClassGrid g;
  g.geometry = {0.5, 0.0, 0.0, 4, 2};  // 2 m × 1 m; cell centres at 0.25, 0.75, 1.25, 1.75
  g.cells.assign(g.geometry.cells(), Cell::kUnknown);
  g.at(1, 0) = Cell::kClear;
  g.at(2, 0) = Cell::kObstacle;
  g.at(3, 0) = Cell::kClear;
  g.at(3, 1) = Cell::kObstacle;
  const double radius = 0.3;
  const auto cls = [&g, radius](double x, double y) {
    return visit_target_class(g.geometry, x, y, radius, [&g](int i, int j) { return g.at(i, j); });
  };
  msg::VisitRequest v;
  v.x = 0.7;
  v.y = 0.2;
  EXPECT_EQ(check_visit(v, true, cls(v.x, v.y)), VisitVerdict::kAccepted);
  EXPECT_EQ(check_visit(v, true, std::nullopt), VisitVerdict::kAccepted);  // no map: not checked
  v.x = 1.0;  // an obstacle cell, 0.25 m from the clear cell (1, 0)'s centre
  EXPECT_EQ(check_visit(v, true, cls(v.x, v.y)), VisitVerdict::kAccepted);
  v.x = 1.25;  // the obstacle cell's centre: the nearest clear centres are 0.5 m away
  EXPECT_EQ(check_visit(v, true, cls(v.x, v.y)), VisitVerdict::kInObstacle);
  v.x = 0.2;  // an unknown cell, 0.55 m from the clear one
  EXPECT_EQ(check_visit(v, true, cls(v.x, v.y)), VisitVerdict::kNotMapped);
  v.x = 1.75;
  v.y = 0.75;  // an obstacle cell with the clear (3, 0) 0.5 m below: too far
  EXPECT_EQ(check_visit(v, true, cls(v.x, v.y)), VisitVerdict::kInObstacle);
  EXPECT_EQ(cls(2.02, 0.25), Cell::kClear);   // just outside the grid, 0.27 m from (3, 0)
  EXPECT_EQ(cls(5.0, 0.25), Cell::kUnknown);  // far outside
  EXPECT_EQ(cls(std::nan(""), 0.25), Cell::kUnknown);
  EXPECT_EQ(cls(1e300, 0.25), Cell::kUnknown);
  EXPECT_EQ(visit_target_class(g.geometry, 0.7, 0.2, 1e9, [&g](int i, int j) { return g.at(i, j); }), Cell::kClear);
  EXPECT_NE(std::string(visit_verdict_text(VisitVerdict::kNotMapped)).find("not mapped"), std::string::npos);
  // The robot's own checks come first: an unlocalised robot is that, whatever the map says.
  EXPECT_EQ(check_visit(v, false, Cell::kUnknown), VisitVerdict::kNotLocalised);
}

}  // namespace
}  // namespace cairn::base
