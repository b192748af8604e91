// The local scan matcher and mapper on synthetic scans of a known room: the field's
// shape, recovery of a known offset from a perturbed guess, a covariance that is wide
// along a corridor, drift well below odometry's, a reported drift covariance that adds
// up only what does (docs/localmap.md), and no allocation per scan.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "firmware/localmap/local_mapper.hpp"
#include "firmware/localmap/work_estimate.hpp"
#ifndef CAIRN_SANITIZED
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn::localmap {
namespace {

constexpr double kPi = std::numbers::pi;

// Walls as segments; a scan is the nearest hit per beam (361 beams over 180°).
struct Segment {
  Vec2 a, b;
};
std::vector<Segment> room() {
  // A 12 × 8 m room with an inner box and an L-shaped wall: enough structure to pin all three axes.
  return {{{0, 0}, {12, 0}}, {{12, 0}, {12, 8}}, {{12, 8}, {0, 8}}, {{0, 8}, {0, 0}},
          {{4, 2}, {5, 2}},  {{5, 2}, {5, 3.5}}, {{5, 3.5}, {4, 3.5}}, {{4, 3.5}, {4, 2}},
          {{8, 5}, {10, 5}}, {{8, 5}, {8, 6.5}}};
}
std::vector<Segment> corridor() { return {{{-50, 0}, {50, 0}}, {{-50, 2}, {50, 2}}}; }

std::vector<Vec2> scan(const std::vector<Segment>& walls, const Pose2& pose, double noise, std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, noise);
  std::vector<Vec2> pts;
  for (int i = 0; i < 361; ++i) {
    const double a = -kPi / 2 + i * kPi / 360;
    const Vec2 d(std::cos(pose.theta + a), std::sin(pose.theta + a));
    double best = 1e9;
    for (const Segment& s : walls) {
      const Vec2 e = s.b - s.a, w = s.a - pose.translation();
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::abs(den) < 1e-12) continue;
      const double t = (w.x() * e.y() - w.y() * e.x()) / den, u = (w.x() * d.y() - w.y() * d.x()) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (best > 14) continue;
    const double r = best + (noise > 0 ? n(*rng) : 0.0);
    pts.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return pts;
}

LikelihoodGrid field_of(const std::vector<Vec2>& pts, const GridConfig& g = {}) {
  LikelihoodGrid grid(g);
  grid.reset(Vec2::Zero());
  grid.add_surface(pts, 0.5);
  grid.finish();
  return grid;
}

TEST(LikelihoodGrid, PeaksOnAPointAndPointsUphill) {
  LikelihoodGrid grid(GridConfig{});
  grid.reset(Vec2(1, 1));
  grid.add_point(Vec2(1.013, 0.987));
  grid.finish();
  EXPECT_GT(grid.sample(Vec2(1.013, 0.987), nullptr), 0.8);  // bilinear between cell centres
  Vec2 g;
  const double v = grid.sample(Vec2(1.06, 0.987), &g);
  EXPECT_GT(v, 0.2);
  EXPECT_LT(v, 0.9);
  EXPECT_LT(g.x(), 0);  // uphill is back towards the point
  EXPECT_EQ(grid.sample(Vec2(3, 3), nullptr), 0.0);
  // The coarse level bounds the fine level from above.
  for (int y = 0; y < grid.size(); ++y)
    for (int x = 0; x < grid.size(); ++x)
      ASSERT_LE(grid.cell(x, y), grid.coarse_cell(x / 4, y / 4));
  // A reset clears everything the last build touched; points off the window are counted.
  grid.reset(Vec2(1, 1));
  grid.finish();
  EXPECT_EQ(grid.sample(Vec2(1.013, 0.987), nullptr), 0.0);
  EXPECT_EQ(grid.coarse_cell(grid.coarse_size() / 2, grid.coarse_size() / 2), 0.0f);
  grid.add_point(Vec2(100, 0));
  EXPECT_EQ(grid.points_outside(), 1u);
}

TEST(LikelihoodGrid, RejectsBadConfiguration) {
  GridConfig g;
  g.size_cells = 510;  // not a multiple of coarse_factor 4
  EXPECT_THROW(LikelihoodGrid{g}, std::invalid_argument);
  g = {};
  g.sigma_m = 0.5;  // 30 cells of kernel
  EXPECT_NE(validate(g), nullptr);
}

// A point on a cell centre stamps exactly the cells within `radius` of it along a row.
int stamped_radius(const GridConfig& g) {
  LikelihoodGrid grid(g);
  grid.reset(Vec2::Zero());
  const int c = g.size_cells / 2;
  grid.add_point(grid.origin() + Vec2::Constant((c + 0.5) * g.resolution_m));
  grid.finish();
  int r = 0;
  while (c + r + 1 < g.size_cells && grid.cell(c + r + 1, c) > 0.0f) ++r;
  return r;
}

TEST(LikelihoodGrid, KernelRadiusIsThreeSigmaRoundedUp) {
  // The default: 3 × 5 cm / 5 cm = 3 cells (49 taps), not 4 (81) from the ratio's rounding error.
  EXPECT_EQ(stamped_radius(GridConfig{}), 3);
  EXPECT_EQ(kernel_radius_cells(GridConfig{}), 3);
  EXPECT_EQ(LikelihoodGrid(GridConfig{}).kernel_radius(), 3);
  GridConfig g;
  g.sigma_m = 0.06;  // 3.6 cells: up to 4
  EXPECT_EQ(kernel_radius_cells(g), 4);
  EXPECT_EQ(stamped_radius(g), 4);
}

TEST(LikelihoodGrid, LargestKernelValidationAcceptsFitsItsBuffers) {
  // 3 × 0.056 / 0.007 is 24 cells (the largest accepted); the grid once made it 25 and
  // wrote past a 49-element stack array (ASan).
  GridConfig g;
  g.resolution_m = 0.007;
  g.sigma_m = 0.056;
  g.size_cells = 128;
  ASSERT_EQ(validate(g), nullptr);
  EXPECT_EQ(kernel_radius_cells(g), LikelihoodGrid::kMaxRadius);
  EXPECT_EQ(stamped_radius(g), LikelihoodGrid::kMaxRadius);
  g.sigma_m = 0.0561;  // 24.04 cells: refused, with the reason
  ASSERT_NE(validate(g), nullptr);
  EXPECT_NE(std::string(validate(g)).find("24 cells"), std::string::npos) << validate(g);
}

TEST(WorkEstimate, TheDefaultConfigurationFitsWithRoomToSpare) {
  const LocalMapConfig c;
  const WorkEstimate w = estimate_work(c, 361);
  EXPECT_EQ(w.kernel_taps, 49);
  EXPECT_GT(w.match_ms, 0.2);
  EXPECT_LT(w.match_ms, 2.5);  // half the 5 ms budget of a 10 ms period
  EXPECT_LT(w.rebuild_ms, 20.0);
  WorkBudget b;
  b.keyframe_interval_s = min_keyframe_interval_s(c, 0.8, 1.5);
  EXPECT_NEAR(b.keyframe_interval_s, 0.17 / 1.5, 1e-12);  // turning makes keyframes fastest
  EXPECT_EQ(check_budget(c, 361, b), "");
}

TEST(WorkEstimate, RefusesMatchingThatDoesNotFitTheRtPeriodWithTheNumbers) {
  // 1 cm cells: validate() accepts them, but the ±0.4 m, ±20° search is 107 angles × 21² shifts at 4 cm.
  LocalMapConfig c;
  c.grid.resolution_m = 0.01;
  ASSERT_EQ(validate(c), nullptr);
  const WorkEstimate w = estimate_work(c, 361);
  EXPECT_GT(w.match_ms, 10.0);
  EXPECT_LT(w.match_ms, 40.0);
  const std::string why = check_budget(c, 361, WorkBudget{});
  EXPECT_NE(why.find("worst-case per-scan matching"), std::string::npos) << why;
  EXPECT_NE(why.find("exceeds the budget 5.0 ms (50 % of the 10.0 ms RT period)"), std::string::npos) << why;
  char ms[32];
  std::snprintf(ms, sizeof ms, "%.1f ms", w.match_ms);
  EXPECT_NE(why.find(ms), std::string::npos) << why;
  EXPECT_NE(why.find(" x 361 points"), std::string::npos) << why;
}

TEST(WorkEstimate, RefusesARebuildThatDoesNotFitBetweenKeyframes) {
  LocalMapConfig c;
  c.keyframes = 100;  // ten times the stamps: ~80 ms against 57 ms (half of 113 ms)
  WorkBudget b;
  b.keyframe_interval_s = min_keyframe_interval_s(c, 0.8, 1.5);
  const std::string why = check_budget(c, 361, b);
  EXPECT_NE(why.find("worst-case keyframe rebuild"), std::string::npos) << why;
  EXPECT_NE(why.find("x 49 kernel taps; 512x512 cells"), std::string::npos) << why;
  EXPECT_NE(why.find("between keyframes"), std::string::npos) << why;
  c.keyframes = 10;
  EXPECT_EQ(check_budget(c, 361, b), "");
}

TEST(WorkEstimate, CountsWhatTheConfigurationBounds) {
  LocalMapConfig c;
  const WorkEstimate few = estimate_work(c, 181), many = estimate_work(c, 2000);
  EXPECT_EQ(many.points, c.max_points);  // the searches and keyframes keep max_points
  EXPECT_NEAR(many.point_evals / few.point_evals, 2000.0 / 181, 1e-9);  // refinement uses them all
  EXPECT_EQ(few.copy_ms, 0.0);  // inline: no request copy
  c.async_rebuild = true;
  EXPECT_GT(estimate_work(c, 181).copy_ms, 0.0);
  c.surface_gap_m = 0;  // no gap filling: a stamp per point
  EXPECT_EQ(estimate_work(c, 181).stamps, 10 * 181);
}

TEST(ScanMatcher, RecoversAKnownOffsetFromAPerturbedGuess) {
  std::mt19937_64 rng(7);
  const Pose2 a{3, 5, 0.2};
  const std::vector<Vec2> ref = scan(room(), a, 0.0, &rng);
  const LikelihoodGrid grid = field_of(ref);
  ScanMatcher matcher(MatchConfig{}, 1024);
  std::uniform_real_distribution<double> off(-0.25, 0.25), offa(-0.2, 0.2);
  int ok = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Pose2 truth{0.3 + 0.1 * trial / 20, -0.15, 0.05};
    const std::vector<Vec2> cur = scan(room(), compose(a, truth), 0.01, &rng);
    const Pose2 guess{truth.x + off(rng), truth.y + off(rng), truth.theta + offa(rng)};
    const MatchResult m = matcher.match(grid, cur, guess);
    const Pose2 e = between(truth, m.pose);
    if (m.ok && std::hypot(e.x, e.y) < 0.01 && std::abs(e.theta) < 0.2 * kPi / 180) ++ok;
    EXPECT_GT(m.score, 0.5);
  }
  EXPECT_GE(ok, 19);
}

TEST(ScanMatcher, CovarianceIsWideAlongACorridor) {
  std::mt19937_64 rng(3);
  const std::vector<Vec2> ref = scan(corridor(), Pose2{0, 1, 0}, 0.0, &rng);
  const LikelihoodGrid grid = field_of(ref);
  ScanMatcher matcher(MatchConfig{}, 1024);
  const MatchResult m = matcher.match(grid, scan(corridor(), Pose2{0.2, 1, 0}, 0.005, &rng), Pose2{0.25, 0.05, 0.02});
  // Across the corridor (y) and in heading the walls pin the pose; along it (x) they do not.
  EXPECT_NEAR(m.pose.y, 0.0, 0.01);
  EXPECT_NEAR(m.pose.theta, 0.0, 0.005);
  // Only the scan's far end (the range limit) says anything about x.
  EXPECT_GT(m.covariance(0, 0), 5 * m.covariance(1, 1)) << m.covariance;
}

TEST(ScanMatcher, EmptyOrTinyScansAreNotMatches) {
  const LikelihoodGrid grid = field_of({Vec2(1, 0), Vec2(1, 0.1), Vec2(1, 0.2)});
  ScanMatcher matcher(MatchConfig{}, 16);
  EXPECT_FALSE(matcher.match(grid, {}, Pose2{}).ok);
  const std::vector<Vec2> far(5, Vec2(500, 500));  // all outside the window
  EXPECT_FALSE(matcher.match(grid, far, Pose2{}).ok);
}

// Drives a loop through the room with odometry that drifts; the mapper's drift must be a
// small fraction of the odometry's. `after_scan` runs after each add_scan (the rebuild
// worker's step in the async tests).
struct LoopOptions {
  bool async = false;
  bool count_allocations = false;
  bool map_relative_drift = false;
  std::function<void(LocalMapper&, const LocalMapUpdate&)> after_scan;
};
struct LoopRun {
  double mapper_error = 0, odom_error = 0, path = 0;
  std::uint64_t allocations = 0;
  LocalMapCounters counters;
  std::vector<Pose2> poses;
  Pose2 last_keyframe;
  Vec2 final_grid_centre = Vec2::Zero();
};
LoopRun drive_loop(const LoopOptions& o) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> unit(0.0, 1.0);
  LocalMapConfig cfg;
  cfg.async_rebuild = o.async;
  cfg.map_relative_drift = o.map_relative_drift;
  LocalMapper mapper(cfg);
  Pose2 truth{2, 1.2, 0};
  mapper.reset(truth);
  Pose2 odom = truth;
  LoopRun r;
  const std::vector<Segment> walls = room();
  std::vector<Vec2> pts;
  pts.reserve(400);
  for (int k = 0; k < 400; ++k) {
    const double v = 0.05, w = (k % 100 > 70) ? 0.05 : 0.0;  // straight, then a bend
    const Pose2 step = arc_motion(v, w, 1.0);
    Pose2 next = compose(truth, step);
    if (next.x < 1 || next.x > 11 || next.y < 1 || next.y > 7 || (next.x > 3.5 && next.x < 5.5 && next.y > 1.5 && next.y < 4))
      next = compose(truth, Pose2{0, 0, 0.3});  // turn in place near walls and the box
    const Pose2 delta = between(truth, next);
    truth = next;
    r.path += std::hypot(delta.x, delta.y);
    // Odometry: 3 % scale error on translation plus noise, and a heading bias.
    const Pose2 noisy{delta.x * 1.03 + 0.003 * unit(rng), delta.y + 0.003 * unit(rng), delta.theta + 0.004 + 0.003 * unit(rng)};
    odom = compose(odom, noisy);
    const std::vector<Vec2> s = scan(walls, truth, 0.01, &rng);
    pts.assign(s.begin(), s.end());
    const Mat3 cov = Vec3(1e-4, 1e-4, 4e-5).asDiagonal();
#ifndef CAIRN_SANITIZED
    if (o.count_allocations && k > 5) testing::start_counting_allocations();
#endif
    const LocalMapUpdate u = mapper.add_scan(pts, noisy, cov);
#ifndef CAIRN_SANITIZED
    if (o.count_allocations && k > 5) r.allocations += testing::stop_counting_allocations();
#endif
    r.poses.push_back(u.pose);
    if (u.keyframe) r.last_keyframe = u.pose;
    if (o.after_scan) o.after_scan(mapper, u);
    if (std::getenv("CAIRN_TEST_VERBOSE"))
      std::printf("%d truth %.3f %.3f %.3f mapper %.3f %.3f %.3f\n", k, truth.x, truth.y, truth.theta, mapper.pose().x,
                  mapper.pose().y, mapper.pose().theta);
  }
  r.mapper_error = std::hypot(mapper.pose().x - truth.x, mapper.pose().y - truth.y);
  r.odom_error = std::hypot(odom.x - truth.x, odom.y - truth.y);
  r.counters = mapper.counters();
  r.final_grid_centre = mapper.grid().centre();
  return r;
}

TEST(LocalMapper, DriftsFarLessThanOdometry) {
  const LoopRun r = drive_loop({});
  EXPECT_GT(r.path, 15.0);
  EXPECT_GT(r.counters.keyframes, 20u);
  EXPECT_GT(r.counters.matched, 390u);
  EXPECT_LT(r.mapper_error, 0.01 * r.path) << "odometry error " << r.odom_error;
  EXPECT_LT(r.mapper_error, 0.25 * r.odom_error);
}

// Creeps in steps of 1.25 mm along x (heading 0: x is the motion's direction) from
// `start`, odometry exact but reported with `odom_cov`, until the second keyframe (the
// first scan is one, the next comes after 0.25 m) or 400 steps. Sums what the mapper
// reports as drift after the first scan (robot frame), with map_relative_drift. `blind`: every scan after the
// first is empty (a laser that sees nothing).
struct Creep {
  Mat3 drift = Mat3::Zero();
  std::vector<double> match_theta_var;  // each match's heading variance
  std::uint64_t matched = 0, keyframes = 0;
};
Creep creep(const std::vector<Segment>& walls, const Pose2& start, const Mat3& odom_cov, bool blind = false) {
  std::mt19937_64 rng(5);
  LocalMapConfig cfg;
  cfg.map_relative_drift = true;
  LocalMapper mapper(cfg);
  mapper.reset(start);
  Pose2 truth = start;
  Creep c;
  for (int k = 0; k < 400 && c.keyframes < 2; ++k) {
    const Pose2 delta = k == 0 ? Pose2{} : Pose2{0.00125, 0, 0};
    truth = compose(truth, delta);
    std::vector<Vec2> pts = scan(walls, truth, 0.01, &rng);
    if (blind && k > 0) pts.clear();
    const LocalMapUpdate u = mapper.add_scan(pts, delta, odom_cov);
    c.keyframes += u.keyframe;
    if (k > 0) c.drift += u.covariance;
    if (!u.matched) continue;
    ++c.matched;
    c.match_theta_var.push_back(u.match.covariance(2, 2));
  }
  return c;
}

// Scans matched against one map share its error: their match covariances must not add
// up in the drift the base integrates. Summed per scan (the old rule), 200 scans in a
// room reported 19 typical matches' worth of heading variance for a pose the map pins.
TEST(LocalMapper, ScansMatchedAgainstOneMapDoNotAddUpInTheDrift) {
  Creep c = creep(room(), Pose2{2, 1.2, 0}, Vec3(1e-6, 1e-6, 1e-6).asDiagonal());
  ASSERT_EQ(c.keyframes, 2u);
  ASSERT_GT(c.matched, 190u);
  std::nth_element(c.match_theta_var.begin(), c.match_theta_var.begin() + c.match_theta_var.size() / 2, c.match_theta_var.end());
  const double typical = c.match_theta_var[c.match_theta_var.size() / 2];  // the median match
  std::printf("heading variance: drift %.3g, a typical match %.3g\n", c.drift(2, 2), typical);
  EXPECT_GT(c.drift(2, 2), 0.0);  // the keyframe carries the error it has relative to the map
  EXPECT_LT(c.drift(2, 2), 2 * typical) << c.drift;
}

// Scans that do not match leave the pose to odometry: their errors do add up, and must
// all reach the drift, inflated for slip as in the fusion.
TEST(LocalMapper, UnmatchedScansAddTheirOdometryToTheDrift) {
  const Mat3 odom = Vec3(1e-6, 2e-6, 3e-7).asDiagonal();
  const Creep c = creep(room(), Pose2{2, 1.2, 0}, odom, /*blind=*/true);
  ASSERT_EQ(c.keyframes, 2u);
  ASSERT_EQ(c.matched, 0u);
  // The steps between the keyframes: 0.25 m of 1.25 mm (exact odometry, no match to move it).
  const double steps = 200;
  const double inflation = LocalMapConfig{}.odometry_inflation;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.drift(i, i), inflation * steps * odom(i, i), inflation * odom(i, i)) << c.drift;
}

#ifndef CAIRN_SANITIZED
TEST(LocalMapper, AddScanNeverAllocates) {
  const LoopRun r = drive_loop({.async = false, .count_allocations = true, .map_relative_drift = false, .after_scan = {}});
  EXPECT_EQ(r.allocations, 0u);
  const LoopRun m = drive_loop({.async = false, .count_allocations = true, .map_relative_drift = true, .after_scan = {}});
  EXPECT_EQ(m.allocations, 0u);
  EXPECT_GT(m.counters.matched, 390u);
}
#endif

void expect_same_poses(const LoopRun& a, const LoopRun& b) {
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    ASSERT_EQ(a.poses[i].x, b.poses[i].x) << "scan " << i;
    ASSERT_EQ(a.poses[i].y, b.poses[i].y) << "scan " << i;
    ASSERT_EQ(a.poses[i].theta, b.poses[i].theta) << "scan " << i;
  }
}

// The worker's step between scans (on this thread): the next scan swaps the new field in
// before matching, as the inline rebuild had it, so the poses are the same to the bit.
TEST(LocalMapperAsync, WorkerBetweenScansGivesTheInlinePoses) {
  const LoopRun inline_run = drive_loop({});
  std::uint64_t built = 0;
  [[maybe_unused]] std::uint64_t worker_allocations = 0;
  const LoopRun async_run = drive_loop({.async = true, .count_allocations = true,
                                        .after_scan = [&](LocalMapper& m, const LocalMapUpdate& u) {
                                          EXPECT_EQ(m.rebuild_requested(), u.keyframe);
#ifndef CAIRN_SANITIZED
                                          testing::start_counting_allocations();
#endif
                                          built += m.build_pending() ? 1 : 0;
#ifndef CAIRN_SANITIZED
                                          worker_allocations += testing::stop_counting_allocations();
#endif
                                          EXPECT_EQ(m.rebuild_state(), u.keyframe ? RebuildState::kReady : RebuildState::kIdle);
                                        }});
  expect_same_poses(inline_run, async_run);
  EXPECT_EQ(built, async_run.counters.keyframes);
  EXPECT_EQ(async_run.counters.rebuilds + 1, built);  // the last one is built, not yet swapped in
  EXPECT_EQ(async_run.counters.rebuilds_deferred, 0u);
#ifndef CAIRN_SANITIZED
  EXPECT_EQ(async_run.allocations, 0u);  // add_scan, swap included
  EXPECT_EQ(worker_allocations, 0u);     // build_pending
#endif
}

// The worker runs only every 15th scan: meanwhile add_scan matches against the field it
// has (the request waits, newer keyframes replace it) and still tracks the robot.
TEST(LocalMapperAsync, MatchingGoesOnAgainstTheOldFieldWhileARebuildWaits) {
  int scans = 0, pending_scans = 0;
  bool waiting = false;
  Vec2 centre_while_waiting = Vec2::Zero();
  const LoopRun r = drive_loop({.async = true, .count_allocations = false,
                                .after_scan = [&](LocalMapper& m, const LocalMapUpdate&) {
                                  if (m.rebuild_requested()) {
                                    if (!waiting) centre_while_waiting = m.grid().centre();
                                    waiting = true;
                                    EXPECT_EQ(m.grid().centre(), centre_while_waiting) << "scan " << scans;
                                    ++pending_scans;
                                  }
                                  // The first field at once (nothing to match against before it).
                                  if ((++scans % 15 == 0 || m.counters().rebuilds == 0) && m.build_pending()) {
                                    EXPECT_TRUE(m.swap_if_ready());
                                    EXPECT_EQ(m.rebuild_state(), RebuildState::kIdle);
                                    waiting = false;
                                  }
                                }});
  EXPECT_GT(pending_scans, 200);
  EXPECT_LT(r.counters.rebuilds, r.counters.keyframes / 2);  // most requests were replaced by newer ones
  EXPECT_GT(r.counters.matched, 390u);
  EXPECT_LT(r.mapper_error, 0.01 * r.path) << "odometry error " << r.odom_error;
  EXPECT_LT(r.mapper_error, 0.25 * r.odom_error);
}

// Spins (yielding) until `done`, at most `limit` times; false if it never came.
template <typename F>
bool spin_until(F done, long limit = 200'000'000) {
  for (long i = 0; i < limit; ++i) {
    if (done()) return true;
    std::this_thread::yield();
  }
  return done();
}

struct Worker {
  explicit Worker(LocalMapper* m)
      : thread([this, m] {
          while (!stop.load(std::memory_order_acquire)) {
            if (!m->build_pending()) std::this_thread::yield();
          }
        }) {}
  ~Worker() {
    stop.store(true, std::memory_order_release);
    thread.join();
  }
  std::atomic<bool> stop{false};
  std::thread thread;
};

// A real worker thread (TSan checks the handoff): after each keyframe the caller waits
// for the field before the next scan, so the poses are the inline ones.
TEST(LocalMapperAsync, WorkerThreadWithCallerWaitingGivesTheInlinePoses) {
  const LoopRun inline_run = drive_loop({});
  std::unique_ptr<Worker> worker;
  bool waited_out = true;
  const LoopRun async_run = drive_loop({.async = true, .count_allocations = false,
                                        .after_scan = [&](LocalMapper& m, const LocalMapUpdate& u) {
                                          if (!worker) worker = std::make_unique<Worker>(&m);
                                          if (u.keyframe)
                                            waited_out &= spin_until([&] { return m.rebuild_state() == RebuildState::kReady; });
                                        }});
  worker.reset();
  EXPECT_TRUE(waited_out) << "the worker never finished a rebuild";
  expect_same_poses(inline_run, async_run);
}

// A free-running worker and a caller that never waits: whatever the interleaving, the
// newest keyframes end up in the field once the caller lets the worker catch up.
TEST(LocalMapperAsync, FreeRunningWorkerEndsWithTheNewestKeyframes) {
  LocalMapConfig cfg;
  cfg.async_rebuild = true;
  LocalMapper mapper(cfg);
  mapper.reset(Pose2{2, 1.2, 0});
  Pose2 truth{2, 1.2, 0}, last_keyframe;
  std::mt19937_64 rng(5);
  const Mat3 cov = Vec3(1e-4, 1e-4, 4e-5).asDiagonal();
  {
    Worker worker(&mapper);
    for (int k = 0; k < 60; ++k) {
      const Pose2 delta{0.06, 0, 0};
      truth = compose(truth, delta);
      const LocalMapUpdate u = mapper.add_scan(scan(room(), truth, 0.01, &rng), delta, cov);
      if (u.keyframe) last_keyframe = u.pose;
    }
    // Let the worker catch up: swap what it built, re-request what came meanwhile, until idle.
    EXPECT_TRUE(spin_until([&] {
      mapper.swap_if_ready();
      return mapper.rebuild_state() == RebuildState::kIdle;
    }));
  }
  EXPECT_LT((mapper.grid().centre() - last_keyframe.translation()).norm(), 1e-9) << mapper.grid().centre();
  const LocalMapCounters& c = mapper.counters();
  EXPECT_GE(c.keyframes, 10u);
  EXPECT_GE(c.rebuilds, 1u);
  EXPECT_LE(c.rebuilds, c.keyframes);
}

TEST(LocalMapperAsync, ResetDropsAPendingRebuild) {
  LocalMapConfig cfg;
  cfg.async_rebuild = true;
  LocalMapper mapper(cfg);
  std::mt19937_64 rng(5);
  const Mat3 cov = Vec3(1e-4, 1e-4, 4e-5).asDiagonal();
  mapper.reset(Pose2{2, 1.2, 0});
  EXPECT_TRUE(mapper.add_scan(scan(room(), Pose2{2, 1.2, 0}, 0.01, &rng), Pose2{}, cov).keyframe);
  EXPECT_TRUE(mapper.rebuild_requested());
  mapper.reset(Pose2{3, 2, 0});  // requested, not claimed: dropped
  EXPECT_EQ(mapper.rebuild_state(), RebuildState::kIdle);
  EXPECT_FALSE(mapper.build_pending());
  (void)mapper.add_scan(scan(room(), Pose2{3, 2, 0}, 0.01, &rng), Pose2{}, cov);
  EXPECT_TRUE(mapper.build_pending());
  mapper.reset(Pose2{4, 2, 0});  // ready: dropped, never swapped in
  EXPECT_FALSE(mapper.swap_if_ready());
  EXPECT_EQ(mapper.counters().rebuilds, 0u);
  EXPECT_LT((mapper.grid().centre() - Vec2(4, 2)).norm(), 1e-9);
}

}  // namespace
}  // namespace cairn::localmap
