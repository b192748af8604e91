// cairn-sim's fleet on simulated time: bit-identical repeats for a seed (whatever the
// worker count), a different seed gives a different run, and the production pipelines
// localise the robots and map the poles of the office world.
#include <gtest/gtest.h>

#include <cstring>

#include "hil/world/world.hpp"
#include "tools/sim/fleet_sim.hpp"
#include "tools/sim/sim_robot.hpp"

namespace cairn {
namespace {

sim::FleetSimConfig office(std::uint64_t seed, int threads, double seconds) {
  sim::FleetSimConfig c;
  c.world_path = std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world";
  c.robots = 3;
  c.duration_s = seconds;
  c.seed = seed;
  c.threads = threads;
  sim::set_tool_speeds(&c);  // cairn-sim's: safety cap 1 m/s, tours at 0.8 m/s looking 0.6 m ahead
  return c;
}

// Bitwise, member by member: Landmark's padding after its id is unspecified.
bool same_bits(const msg::Landmark& p, const msg::Landmark& q) {
  return p.id == q.id && std::memcmp(&p.x, &q.x, sizeof p.x) == 0 && std::memcmp(&p.y, &q.y, sizeof p.y) == 0 &&
         std::memcmp(p.cov.data(), q.cov.data(), sizeof p.cov) == 0;
}

bool same_run(const sim::FleetSim& a, const sim::FleetSim& b) {
  const auto &sa = a.samples(), &sb = b.samples();
  if (sa.size() != sb.size()) return false;
  for (std::size_t i = 0; i < sa.size(); ++i) {
    const auto &x = sa[i], &y = sb[i];
    // Bitwise: a repeat must not differ even in the last bit.
    if (x.t != y.t || x.robot != y.robot || x.has_global != y.has_global ||
        std::memcmp(&x.truth, &y.truth, sizeof x.truth) != 0 || std::memcmp(&x.local, &y.local, sizeof x.local) != 0 ||
        std::memcmp(&x.global, &y.global, sizeof x.global) != 0)
      return false;
  }
  const auto la = a.landmarks(), lb = b.landmarks();
  if (la.size() != lb.size()) return false;
  for (std::size_t i = 0; i < la.size(); ++i)
    if (!same_bits(la[i], lb[i])) return false;
  return true;
}

TEST(FleetSim, SameSeedSameBitsWhateverTheThreads) {
  sim::FleetSim a(office(7, 1, 20)), b(office(7, 2, 20)), c(office(8, 2, 20));
  a.run();
  b.run();
  c.run();
  ASSERT_FALSE(a.samples().empty());
  EXPECT_TRUE(same_run(a, b));
  EXPECT_FALSE(same_run(a, c));  // the seed matters: noise and slip differ
}

TEST(FleetSim, OfficeRobotsAreLocalisedAndPolesMapped) {
  sim::FleetSim f(office(3, 2, 40));
  f.run();
  const sim::FleetSummary s = f.summary(1.0);
  ASSERT_EQ(s.robots.size(), 3u);
  for (const auto& r : s.robots) {
    EXPECT_GT(r.distance_m, 15.0) << "robot " << r.id;  // they drove their tours
    EXPECT_EQ(r.bumps, 0u) << "robot " << r.id;
    EXPECT_GE(r.matched, r.scans * 95 / 100) << "robot " << r.id;
    // The base's estimate (CCML over the poles) against ground truth.
    EXPECT_LT(r.global_rmse_m, 0.10) << "robot " << r.id;
  }
  EXPECT_GE(s.landmarks, 8u);
  EXPECT_EQ(s.landmarks_far, 0u);
  EXPECT_LT(s.landmark_rmse_m, 0.10);
  // The base's central map: every LaserScan placed by the fusion's frame estimate, against
  // the world's ground truth. A placement 1.1 degrees off gives 90.9 % agreement and a mean
  // wall offset of 0.86 cell here. (Issue 14's bar, 97 % and every wall within one cell,
  // is met with true poses, mapper_accuracy_test; through the estimator see
  // FleetSimMap below and docs/mapper.md.)
  EXPECT_EQ(s.map_scans_unplaced, 0u);
  EXPECT_GT(s.map_scans, 400u);  // 3 robots x 40 s x 37.5 scans/s / every 10th
  EXPECT_GE(s.map.agreement, 0.95);
  EXPECT_LE(s.map.wall_offset_mean_cells(), 0.5);
}

// Issue 14's bar for the central map, through the estimator: the office, three robots on
// their tours, 150 simulated s: at least 97 % of known cells agree with the world, and the
// walls lie within one cell: here 95 % of the obstacle cells (p95). Every scan is placed
// at the fusion's frame of the robot at the scan's time (base::MapFrames); when every
// stored scan was redrawn with the robot's latest frame instead, this run gave 94.9 %
// agreement and a wall 1.9 cells off. Every obstacle cell within one cell (the max) holds
// in 5 of seeds 1-8 only: in the others one stretch of wall seen from afar at the end of a
// tour is 1.5 cells off, from a heading error of ~1.5° (docs/mapper.md).
// (A separate CTest, fleet_sim_map_test: it runs in the release pass only.)
TEST(FleetSimMap, OfficeToursMapAgreesWithTheWorldAndEveryWallWithinACell) {
  sim::FleetSim f(office(3, 2, 150));
  f.run();
  const sim::FleetSummary s = f.summary(1.0);
  std::printf("agreement %.4f, coverage %.4f, wall offset mean %.2f p95 %.2f max %.2f cells, %llu scans\n", s.map.agreement,
              s.map.coverage, s.map.wall_offset_mean_cells(), s.map.wall_offset_p95_m / s.map.resolution,
              s.map.wall_offset_max_cells(), static_cast<unsigned long long>(s.map_scans));
  EXPECT_EQ(s.map_scans_unplaced, 0u);
  EXPECT_GE(s.map.agreement, 0.97);
  EXPECT_LE(s.map.wall_offset_mean_cells(), 0.5);
  EXPECT_LE(s.map.wall_offset_p95_m / s.map.resolution, 1.0);
}

double fleet_rmse(const sim::FleetSummary& s) {
  double sum = 0;
  for (const auto& r : s.robots) sum += r.global_rmse_m;
  return sum / static_cast<double>(s.robots.size());
}

// The pole-free hall: a robot's only correction is another robot. The fleet fusing its
// sightings must be better than each robot localised alone (the cooperative seed's claim).
// With map_relative_drift it is (0.063 against 0.287 m on this seed). With the default
// drift, each scan's fused covariance summed, it is only 11 % better on seeds 1–6: the base thinks
// every heading far less certain than it is (σ 0.18 rad where the error is 0.002 rad) and
// lets the sightings turn the fleet as a whole. The default stays until the bias that then
// turns a landmark map is found (docs/markers.md).
// Robots that see each other (docs/markers.md): the pole-free hall, three robots on
// concentric loops in one world. Their coded markers are read (three in four: < 1/3 unread
// asserted, ~25 % seen), the unread ones paired with the robot that explains them, and the
// sightings fused; no
// robot becomes a landmark (slivers of bodies were poles before the occlusion rule: 14
// here); and the beams on the others' moving bodies are kept out of each robot's scan
// matching (matched, they dragged robot 1's local frame to 2.1 m RMSE; alone it is 0.33 m).
TEST(FleetSimMap, RobotsInOneWorldReadEachOthersMarkersAndTheFleetIsBetterForIt) {
  sim::FleetSimConfig c = office(7, 2, 150);
  c.world_path = std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/hall-bare.world";
  c.shared_world = true;
  c.robot.localmap.map_relative_drift = true;  // with the default drift the fleet is worse (docs/markers.md)
  sim::FleetSimConfig alone_cfg = c;
  alone_cfg.robot_observations = false;
  sim::FleetSim alone(alone_cfg);
  alone.run();
  const sim::FleetSummary a = alone.summary(1.0);
  sim::FleetSim f(c);
  f.run();
  const sim::FleetSummary s = f.summary(1.0);
  std::printf("global rmse alone %.3f %.3f %.3f (fleet %.3f), cooperative %.3f %.3f %.3f (fleet %.3f) m\n",
              a.robots[0].global_rmse_m, a.robots[1].global_rmse_m, a.robots[2].global_rmse_m, fleet_rmse(a),
              s.robots[0].global_rmse_m, s.robots[1].global_rmse_m, s.robots[2].global_rmse_m, fleet_rmse(s));
  EXPECT_LT(fleet_rmse(s), fleet_rmse(a));
  EXPECT_EQ(a.robot_observations_used, 0u);
  std::printf("sightings %llu, unread %llu, fused %llu; landmarks %zu; local rmse %.3f %.3f %.3f m\n",
              static_cast<unsigned long long>(s.robot_sightings), static_cast<unsigned long long>(s.robot_sightings_unidentified),
              static_cast<unsigned long long>(s.robot_observations_used), s.landmarks, s.robots[0].local_rmse_m,
              s.robots[1].local_rmse_m, s.robots[2].local_rmse_m);
  EXPECT_GT(s.robot_sightings, 5000u);
  EXPECT_LT(s.robot_sightings_unidentified, s.robot_sightings / 3);
  EXPECT_GT(s.robot_sightings_paired, s.robot_sightings_unidentified * 9 / 10);
  EXPECT_GT(s.robot_observations_used, s.robot_sightings / 2);
  // The sightings' stated covariance is the body fit's plus a 1 cm motion allowance
  // (features.hpp). Their mean NIS was 0.04 with the landmarks' 3 cm / 0.01 rad (10x the
  // error); 0.26 now. It stays below 2 because the base's pose covariance, not the
  // sighting's, dominates the innovation (robot 2 rejects 8 % of its scans and is carried
  // far too cautiously, docs/markers.md). Too tight a covariance shows as a mean above 2:
  // without the motion allowance it is 3.2, and the fleet's pose NEES 34.
  ASSERT_TRUE(s.sighting_nis_mean.has_value());
  std::printf("sightings' mean NIS %.2f\n", *s.sighting_nis_mean);
  EXPECT_GT(*s.sighting_nis_mean, 0.15);
  EXPECT_LT(*s.sighting_nis_mean, 2.0);
  EXPECT_EQ(s.landmarks, 0u);
  for (const auto& r : s.robots) {
    EXPECT_EQ(r.bumps, 0u) << "robot " << r.id;
    EXPECT_LT(r.local_rmse_m, 1.0) << "robot " << r.id;
  }
}

}  // namespace
}  // namespace cairn

namespace cairn {
namespace {

double closest_approach(const sim::FleetSim& f) { return f.closest_approach_m().value_or(1e9); }

// In one shared world robots collide and stop; they never pass through each other. In
// separate worlds (the default) the office tours cross, so the check can fail. The
// collision is the world's: shown with the robots' protective fields off. With them on
// (the default) the robots stop before touching: no blocked step at all.
TEST(FleetSim, InASharedWorldRobotsCollideInsteadOfPassingThrough) {
  sim::FleetSimConfig separate = office(7, 1, 30);
  sim::FleetSim apart(separate);
  apart.run();
  sim::FleetSimConfig shared = separate;
  shared.shared_world = true;
  shared.robot.field.enabled = false;
  sim::FleetSim together(shared);
  together.run();
  shared.robot.field.enabled = true;
  sim::FleetSim guarded(shared);
  guarded.run();
  const double body = 2 * 0.3;  // two bodies of SimRobotConfig's default radius
  auto blocked_steps = [](const sim::FleetSim& f) {
    std::uint64_t n = 0;
    for (const auto& r : f.summary(1.0).robots) n += r.bumps;
    return n;
  };
  const std::uint64_t bumps = blocked_steps(together), guarded_bumps = blocked_steps(guarded);
  std::printf("closest approach: separate worlds %.3f m, shared world %.3f m (bodies touch at %.2f m); %llu blocked steps; "
              "with the protective field %.3f m, %llu blocked steps\n",
              closest_approach(apart), closest_approach(together), body, static_cast<unsigned long long>(bumps),
              closest_approach(guarded), static_cast<unsigned long long>(guarded_bumps));
  EXPECT_LT(closest_approach(apart), body) << "the tours no longer cross: this test shows nothing";
  EXPECT_GE(closest_approach(together), body - 0.01);
  EXPECT_GT(bumps, 0u);
  EXPECT_GT(closest_approach(guarded), body + 0.02);
  EXPECT_EQ(guarded_bumps, 0u);
}

struct NoOutputs : firmware::RobotOutputs {
  void odometry(const msg::OdometryIncrement&) override {}
  void laser(const msg::LaserScan&) override {}
  void features(const msg::FeatureObservations&) override {}
};

// cairn-sim's stand-in recovery backs a robot off for a while after a bump. A back-off
// asked for while one runs (the robot bumped into what is behind it) ends it: restarting
// it pushed the robot on backwards into a wall for 20 s in one of world D's runs.
TEST(SimRobot, ABumpWhileBackingOffEndsTheBackOff) {
  hil::World world = hil::World::parse("bounds 0 0 10 10\nbox 0 0 10 10\nstart 1 5 5 0\n", "room");
  sim::SimRobotConfig rc;
  rc.start = Pose2{5, 5, 0};
  rc.scripted = false;
  rc.slip_sigma = 0;
  sim::SimRobot robot(rc, &world);
  NoOutputs out;
  const Nanos dt = 5 * kNanosPerMilli, back_off = 1500 * kNanosPerMilli;
  Nanos now = 0;
  auto run_until = [&](Nanos until) {
    for (; now < until; now += dt) {
      if (now > 0) robot.physics(now - dt, dt);
      robot.tick(now, out);
    }
  };
  run_until(kNanosPerSecond);  // settled, standing
  const double x0 = robot.truth().x;
  robot.set_path({}, now, back_off, 0.15);
  run_until(now + 500 * kNanosPerMilli);
  const double x1 = robot.truth().x;
  EXPECT_LT(x1, x0 - 0.03) << "backing off (west)";
  robot.set_path({}, now, back_off, 0.15);  // bumped while backing off
  run_until(now + kNanosPerSecond);
  EXPECT_NEAR(robot.truth().x, x1, 0.03) << "the back-off ended: the robot stands on its empty path";
  // A back-off asked for when none runs starts one, as before.
  const double x2 = robot.truth().x;
  robot.set_path({}, now, back_off, 0.15);
  run_until(now + kNanosPerSecond);
  EXPECT_LT(robot.truth().x, x2 - 0.08);
}

}  // namespace
}  // namespace cairn
