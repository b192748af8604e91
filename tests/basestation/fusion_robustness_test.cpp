// Issue 16, item 1: hostile or broken input to the base's fusion is refused and counted by
// reason (reject.hpp), never thrown, never turns the state non-finite, never silences a
// robot, never grows memory without bound, never lets an unknown robot define the frame,
// and never lets relocation lock on to an ambiguous layout.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "basestation/fusion.hpp"
#include "basestation/state_store.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"

namespace cairn::base {
namespace {

using fleet_stream::FleetScenario;

/// Robots 1..known listed with their true start; the rest listed without a start pose.
FusionConfig config_for(const FleetScenario& s, int known = 99) {
  FusionConfig c;
  for (std::size_t r = 0; r < s.starts.size(); ++r) {
    RobotPrior p;
    p.known = static_cast<int>(r) < known;
    p.pose = p.known ? s.starts[r] : Pose2{};
    p.sigma = p.known ? Vec3(0.05, 0.05, 0.01) : Vec3(100, 100, 3);
    c.robots[static_cast<std::uint16_t>(r + 1)] = p;
  }
  return c;
}

using fleet_stream::feed;

template <typename M>
M last_of(const FleetScenario& s, std::uint16_t robot) {
  M last{};
  for (const auto& m : s.messages) {
    if (const auto* x = std::get_if<M>(&m); x && x->robot_id == robot) last = *x;
  }
  return last;
}

msg::FeatureObservations robot_marker(const FleetScenario& s, std::int32_t marker) {
  msg::FeatureObservations bad = last_of<msg::FeatureObservations>(s, 1);
  bad.seq += 1;
  bad.n_features = 1;
  bad.features[0] = {msg::FeatureKind::kRobot, marker, 3.0, 0.1, {0.01, 0, 0, 0.001}};
  return bad;
}

// ---- (a) marker ids

TEST(FusionRobustness, RobotMarkerOutsideUint16IsRejectedNotThrown) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 40);
  Fusion f(config_for(s));
  for (const auto& m : s.messages) feed(&f, m);
  ASSERT_TRUE(f.localized(2));
  Fusion::Result r{};
  EXPECT_NO_THROW(r = f.on_features(robot_marker(s, 65536 + 2)));  // passed the uint16 lookup as robot 2
  EXPECT_EQ(r, Fusion::Result::kRejected);
  EXPECT_EQ(f.on_features(robot_marker(s, 0)), Fusion::Result::kRejected);
  EXPECT_EQ(f.on_features(robot_marker(s, 1)), Fusion::Result::kRejected);  // its own id
  EXPECT_EQ(f.counters().rejected[Reject::kBadMarker], 3u);
  EXPECT_TRUE(f.check(robot_marker(s, 65536 + 2)).has_value());  // the node refuses it before logging
}

TEST(FusionRobustness, ALoggedMessageThatThrowsIsSkippedOnReplay) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 40);
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-replay-throw-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  {
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    store.restore(&f);
    for (const auto& m : s.messages) std::visit([&](const auto& x) { store.append(x, 0); }, m);
    // What an older base logged before applying (and then died on, at every restart):
    // StateStore::append does not check; the node checks before it appends.
    store.append(robot_marker(s, 65536 + 2), 0);
  }
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  RestoreReport rep;
  EXPECT_NO_THROW(rep = store.restore(&f));
  EXPECT_EQ(rep.replayed_features + rep.replayed_odometry, s.messages.size() + 1);
  // Refused by the checks on replay (and, had it thrown, skipped and counted as apply_failed).
  EXPECT_EQ(f.counters().rejected[Reject::kBadMarker] + rep.failed_records, 1u);
  EXPECT_TRUE(f.localized(1));
  std::filesystem::remove_all(dir);
}

// ---- (b) magnitudes, covariance shape, χ² gate, non-finite state

TEST(FusionRobustness, HugeDeltaAndIndefiniteCovarianceAreRejectedAndStateUnchanged) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 20);
  Fusion f(config_for(s));
  for (const auto& m : s.messages) feed(&f, m);
  const Eigen::VectorXd x0 = f.filter().mean();
  const Eigen::MatrixXd P0 = f.filter().covariance();
  msg::OdometryIncrement o = last_of<msg::OdometryIncrement>(s, 1);
  o.seq += 1;
  msg::OdometryIncrement huge = o;
  huge.delta = {1e300, 1e300, 0};
  huge.delta_cov = {1e300, 0, 0, 0, 1e300, 0, 0, 0, 1};
  EXPECT_EQ(f.on_odometry(huge), Fusion::Result::kRejected);
  msg::OdometryIncrement indefinite = o;
  indefinite.delta_cov = {1, 2, 0, 2, 1, 0, 0, 0, 1};  // eigenvalues -1, 3, 1: diagonal positive
  EXPECT_EQ(f.on_odometry(indefinite), Fusion::Result::kRejected);
  EXPECT_EQ(f.counters().rejected[Reject::kOutOfBounds], 1u);
  EXPECT_EQ(f.counters().rejected[Reject::kBadCovariance], 1u);
  EXPECT_TRUE(f.filter().mean().allFinite());
  EXPECT_EQ(f.filter().mean(), x0);
  EXPECT_EQ(f.filter().covariance(), P0);
  EXPECT_EQ(f.on_odometry(o), Fusion::Result::kApplied);  // the genuine one still goes through
}

TEST(FusionRobustness, ObservationFailingTheInnovationGateIsNotApplied) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 40);
  Fusion f(config_for(s));
  for (const auto& m : s.messages) feed(&f, m);
  const Eigen::VectorXd x0 = f.filter().mean();
  msg::FeatureObservations far = robot_marker(s, 2);
  far.features[0].range = 60.0;  // robot 2 is a few metres away: 60 m is no observation of it
  far.features[0].cov = {1e-4, 0, 0, 1e-5};
  EXPECT_EQ(f.on_features(far), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().rejected[Reject::kInnovationGate], 1u);
  EXPECT_EQ(f.filter().mean(), x0);
}

// ---- (c) boot epochs and seq

TEST(FusionRobustness, RebootedRobotIsHeardFromItsNewEpoch) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 100);
  FusionConfig c = config_for(s);
  Fusion f(c);
  const std::size_t half = s.messages.size() / 2;
  for (std::size_t k = 0; k < half; ++k) feed(&f, s.messages[k]);  // epoch 0
  const Pose2 before = f.filter().robot_pose(1);
  // The robot restarts: seq from 1 and a local frame at its origin, under a new epoch.
  const msg::OdometryIncrement last = last_of<msg::OdometryIncrement>(s, 1);
  const auto applied = f.counters().odometry_applied;
  msg::OdometryIncrement o{};
  o.robot_id = 1;
  o.boot_epoch = 1234;
  o.seq = 1;
  o.delta_cov = {1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-5};
  EXPECT_EQ(f.on_odometry(o), Fusion::Result::kApplied);
  o.seq = 2;
  o.delta = {0.1, 0, 0};
  o.local_pose = {0.1, 0, 0};
  EXPECT_EQ(f.on_odometry(o), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().odometry_applied, applied + 2);
  EXPECT_EQ(f.counters().robots_restarted, 1u);
  const Pose2 after = f.filter().robot_pose(1);
  EXPECT_NEAR(std::hypot(after.x - before.x, after.y - before.y), 0.1, 1e-6);  // moved on from where it was
  msg::PoseCorrection corr;
  ASSERT_TRUE(f.correction(1, 0, &corr));
  EXPECT_NEAR(compose(corr.local_to_global, o.local_pose).x, after.x, 1e-9);  // re-anchored local frame
  // A late message of the old epoch is stale, not a restart back.
  msg::OdometryIncrement old = last;
  old.seq += 1;
  EXPECT_EQ(f.on_odometry(old), Fusion::Result::kRejected);
  EXPECT_EQ(f.counters().rejected[Reject::kStaleEpoch], 1u);
  EXPECT_EQ(f.counters().robots_restarted, 1u);
}

TEST(FusionRobustness, OneHugeSeqDoesNotSilenceARobot) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 40);
  Fusion f(config_for(s));
  const std::size_t half = s.messages.size() / 2;
  for (std::size_t k = 0; k < half; ++k) feed(&f, s.messages[k]);
  msg::OdometryIncrement o = last_of<msg::OdometryIncrement>(s, 1);
  o.seq = UINT32_MAX;
  EXPECT_EQ(f.on_odometry(o), Fusion::Result::kRejected);
  msg::FeatureObservations ft = last_of<msg::FeatureObservations>(s, 1);
  ft.seq = UINT32_MAX;
  EXPECT_EQ(f.on_features(ft), Fusion::Result::kRejected);
  EXPECT_EQ(f.counters().rejected[Reject::kSeqJump], 2u);
  const auto odo = f.counters().odometry_applied, feat = f.counters().feature_messages_applied;
  for (std::size_t k = half; k < s.messages.size(); ++k) feed(&f, s.messages[k]);
  EXPECT_EQ(f.counters().odometry_applied, odo + 20);
  EXPECT_EQ(f.counters().feature_messages_applied, feat + 10);
}

// ---- (d) bounded memory

TEST(FusionRobustness, RobotsOutsideTheFleetAreRefusedOrCapped) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 10);
  FusionConfig c = config_for(s);
  Fusion closed(c);
  c.allow_unknown_robots = true;
  c.max_unknown_robots = 3;
  Fusion open(c);
  for (std::uint16_t id = 100; id < 1100; ++id) {
    msg::OdometryIncrement o{};
    o.robot_id = id;
    o.seq = 1;
    closed.on_odometry(o);
    open.on_odometry(o);
    msg::FeatureObservations ft{};
    ft.robot_id = id;
    ft.seq = 1;
    ft.odom_seq = 5;  // would wait for odometry
    closed.on_features(ft);
    open.on_features(ft);
  }
  EXPECT_EQ(closed.robots().size(), 0u);
  EXPECT_EQ(closed.counters().rejected[Reject::kUnknownRobot], 2000u);
  EXPECT_EQ(open.robots().size(), 3u);
  EXPECT_EQ(open.counters().rejected[Reject::kRobotCap], 2 * 997u);
}

TEST(FusionRobustness, LandmarksAreCappedAndOneOffClutterIsPruned) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 200);
  FusionConfig c = config_for(s);
  c.max_landmarks = 3;
  Fusion capped(c);
  for (const auto& m : s.messages) feed(&capped, m);
  EXPECT_EQ(capped.filter().feature_count(), 3u);
  EXPECT_GT(capped.counters().rejected[Reject::kLandmarkCap], 0u);

  c = config_for(s);
  c.landmark_confirm_age = 20;  // feature messages
  Fusion f(c);
  const std::size_t half = s.messages.size() / 2;
  for (std::size_t k = 0; k < half; ++k) feed(&f, s.messages[k]);
  const std::size_t poles = f.filter().feature_count();
  // One spurious return 1 m ahead (no pole there), seen once, in the next genuine message.
  std::size_t next = half;
  while (!std::holds_alternative<msg::FeatureObservations>(s.messages[next])) feed(&f, s.messages[next++]);
  msg::FeatureObservations with_clutter = std::get<msg::FeatureObservations>(s.messages[next]);
  with_clutter.features[with_clutter.n_features++] = {msg::FeatureKind::kLandmark, -1, 1.0, 0.0, {0.0025, 0, 0, 7e-4}};
  f.on_features(with_clutter);
  EXPECT_EQ(f.filter().feature_count(), poles + 1);
  for (std::size_t k = next + 1; k < s.messages.size(); ++k) feed(&f, s.messages[k]);
  EXPECT_EQ(f.counters().landmarks_pruned, 1u);
  EXPECT_EQ(f.filter().feature_count(), poles);
}

TEST(FusionRobustness, OneRobotsWaitingFeaturesDoNotBlockAnother) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 60);
  Fusion f(config_for(s));
  // Robot 2's features arrive, but none of its odometry: they wait in its own bounded queue.
  for (const auto& m : s.messages) {
    const auto* ft = std::get_if<msg::FeatureObservations>(&m);
    if (ft && ft->robot_id == 2) f.on_features(*ft);
  }
  for (const auto& m : s.messages) {
    if (std::visit([](const auto& x) { return x.robot_id; }, m) == 1) feed(&f, m);
  }
  EXPECT_EQ(f.counters().feature_messages_applied, 30u);  // all of robot 1's
  EXPECT_EQ(f.counters().pending_overflow, 0u);
}

// ---- (e) the map frame

TEST(FusionRobustness, AnUnknownRobotSpeakingFirstDoesNotDefineTheFrame) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 100);
  FusionConfig c = config_for(s, 1);
  c.robots.erase(2);  // robot 2 is not in the configured fleet
  c.allow_unknown_robots = true;
  Fusion f(c);
  for (const auto& m : s.messages) {
    if (std::visit([](const auto& x) { return x.robot_id; }, m) == 2) feed(&f, m);
  }
  EXPECT_FALSE(f.localized(2));
  EXPECT_EQ(f.filter().feature_count(), 0u);  // it mapped nothing in a frame of its own
  for (const auto& m : s.messages) {
    if (std::visit([](const auto& x) { return x.robot_id; }, m) == 1) feed(&f, m);
  }
  ASSERT_TRUE(f.localized(1));
  const Pose2 est = f.filter().robot_pose(1);
  EXPECT_LT(std::hypot(est.x - s.truth_end[0].x, est.y - s.truth_end[0].y), 0.2);  // in the configured frame
}

// ---- (f) relocation

msg::FeatureObservations square_view(std::uint16_t robot, std::uint32_t seq, const Pose2& truth) {
  msg::FeatureObservations f{};
  f.robot_id = robot;
  f.seq = seq;
  f.odom_seq = seq;
  for (const Vec2& p : {Vec2(4, 4), Vec2(-4, 4), Vec2(-4, -4), Vec2(4, -4)}) {
    const RangeBearing z = observe_point(truth, p);
    f.features[f.n_features++] = {msg::FeatureKind::kLandmark, -1, z.range, z.bearing, {0.0025, 0, 0, 3e-4}};
  }
  return f;
}

msg::OdometryIncrement standing(std::uint16_t robot, std::uint32_t seq) {
  msg::OdometryIncrement o{};
  o.robot_id = robot;
  o.seq = seq;
  o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-7};
  return o;
}

TEST(FusionRobustness, RelocationRefusesASymmetricLayout) {
  FusionConfig c;
  RobotPrior p1;
  p1.known = true;
  p1.sigma = Vec3(0.01, 0.01, 0.005);
  c.robots[1] = p1;
  c.robots[2] = RobotPrior{};  // listed, start unknown
  Fusion f(c);
  for (std::uint32_t k = 1; k <= 5; ++k) {
    f.on_odometry(standing(1, k));
    f.on_features(square_view(1, k, {}));
  }
  ASSERT_EQ(f.filter().feature_count(), 4u);
  for (std::uint32_t k = 1; k <= 5; ++k) {
    f.on_odometry(standing(2, k));
    f.on_features(square_view(2, k, {1.0, 0.5, 0.3}));
  }
  EXPECT_FALSE(f.localized(2));
  EXPECT_EQ(f.counters().rejected[Reject::kRelocationAmbiguous], 5u);
}

TEST(FusionRobustness, RelocationRefusesAnIncompleteSearch) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 600);
  FusionConfig c = config_for(s, 1);
  c.jcbb.max_nodes = 3;  // far too small to finish any search
  Fusion f(c);
  for (const auto& m : s.messages) feed(&f, m);
  EXPECT_FALSE(f.localized(2));
  EXPECT_GT(f.counters().rejected[Reject::kSearchIncomplete], 0u);
}

}  // namespace
}  // namespace cairn::base
