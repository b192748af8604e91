// The base station's fusion on a fleet message stream, its robustness to bad, late,
// duplicate and missing messages, and crash-safe persistence (snapshot + log replay).
#include "basestation/fusion.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <filesystem>
#include <sstream>

#include "basestation/state_store.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"

namespace cairn::base {
namespace {

using fleet_stream::FleetScenario;

FusionConfig config_for(const FleetScenario& s, bool know_all = true) {
  FusionConfig c;
  c.allow_unknown_robots = !know_all;  // the others join unlisted, by relocation
  for (std::size_t r = 0; r < s.starts.size(); ++r) {
    if (!know_all && r > 0) continue;
    RobotPrior p;
    p.known = true;
    p.pose = s.starts[r];
    p.sigma = Vec3(0.05, 0.05, 0.01);
    c.robots[static_cast<std::uint16_t>(r + 1)] = p;
  }
  return c;
}

using fleet_stream::feed;

double position_error(const Fusion& f, const FleetScenario& s, int r) {
  const Pose2 est = f.filter().robot_pose(static_cast<ccml::RobotId>(r + 1));
  return std::hypot(est.x - s.truth_end[r].x, est.y - s.truth_end[r].y);
}

TEST(Fusion, ThreeRobotsStayLocalisedAndMapThePoles) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(3, 600);
  Fusion f(config_for(s));
  for (const auto& m : s.messages) feed(&f, m);
  for (int r = 0; r < 3; ++r) EXPECT_LT(position_error(f, s, r), 0.15) << "robot " << r + 1;
  EXPECT_GE(f.filter().feature_count(), 8u);
  EXPECT_LE(f.filter().feature_count(), 10u);  // no duplicates of the 10 poles
  for (ccml::FeatureId id : f.filter().feature_ids()) {
    double best = 1e9;
    for (const Vec2& p : s.poles) best = std::min(best, (f.filter().feature(id) - p).norm());
    EXPECT_LT(best, 0.2) << "feature " << id;
  }
  EXPECT_GT(f.counters().observations_used, 1000u);
  msg::PoseCorrection c;
  ASSERT_TRUE(f.correction(2, 123, &c));
  EXPECT_EQ(c.robot_id, 2);
  EXPECT_NEAR(c.global_pose.x, f.filter().robot_pose(2).x, 1e-12);
  std::vector<msg::Landmark> map;
  f.landmarks(&map);
  EXPECT_EQ(map.size(), f.filter().feature_count());
}

// Robots' sightings of each other (docs/markers.md): those with an id enter the update and
// are counted; a sighting whose marker was not read (id -1) is counted and not fused; with
// robot_observations off none is fused and the estimate is that of landmarks alone.
TEST(Fusion, RobotSightingsWithAnIdAreFusedAndCounted) {
  FleetScenario s = fleet_stream::make_fleet_scenario(3, 300);
  std::uint64_t with_id = 0, unread = 0;
  std::size_t k = 0;
  for (auto& m : s.messages) {
    auto* f = std::get_if<msg::FeatureObservations>(&m);
    if (!f) continue;
    for (std::uint8_t i = 0; i < f->n_features; ++i) {
      if (f->features[i].kind != msg::FeatureKind::kRobot) continue;
      if (++k % 4 == 0) {  // every fourth: its code not read
        f->features[i].marker_id = -1;
        ++unread;
      } else {
        ++with_id;
      }
    }
  }
  ASSERT_GT(with_id, 100u);
  Fusion on(config_for(s));
  FusionConfig c = config_for(s);
  c.robot_observations = false;
  Fusion off(c);
  for (const auto& m : s.messages) {
    feed(&on, m);
    feed(&off, m);
  }
  EXPECT_EQ(on.counters().robot_sightings, with_id + unread);
  EXPECT_EQ(on.counters().robot_sightings_unidentified, unread);
  // The unread ones are paired with the robot that explains them (the robots are metres
  // apart here); all but a few (the gate, the first messages before both robots are
  // localised) fused.
  EXPECT_GT(on.counters().robot_sightings_paired, unread * 9 / 10);
  EXPECT_EQ(on.counters().robot_sightings_paired + on.counters().robot_sightings_unpaired, unread);
  EXPECT_GT(on.counters().robot_observations_used, (with_id + unread) * 9 / 10);
  EXPECT_LE(on.counters().robot_observations_used, with_id + unread);
  EXPECT_EQ(off.counters().robot_sightings, with_id + unread);
  EXPECT_EQ(off.counters().robot_observations_used, 0u);
  // The landmarks' observations are the same either way, but for the odd one the gate
  // decides differently on the other estimate.
  const double landmarks_on = static_cast<double>(on.counters().observations_used - on.counters().robot_observations_used);
  EXPECT_NEAR(landmarks_on, static_cast<double>(off.counters().observations_used), 0.01 * static_cast<double>(off.counters().observations_used));
}

// An unread sighting is paired only when one robot alone explains it: one of robot 2 where
// the filter has it is; the same one twice in a scan (two sightings, one robot) is
// neither; one where no robot is, is not.
TEST(Fusion, AnUnreadSightingIsPairedOnlyWithTheOneRobotThatExplainsIt) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(3, 300);
  Fusion f(config_for(s));
  msg::OdometryIncrement last{};
  std::uint32_t feature_seq = 0;
  for (const auto& m : s.messages) {
    feed(&f, m);
    if (const auto* o = std::get_if<msg::OdometryIncrement>(&m); o && o->robot_id == 1) last = *o;
    if (const auto* x = std::get_if<msg::FeatureObservations>(&m); x && x->robot_id == 1) feature_seq = x->seq;
  }
  ASSERT_TRUE(f.localized(1) && f.localized(2) && f.localized(3));
  const RangeBearing at2 = observe_point(f.filter().robot_pose(1), f.filter().robot_pose(2).translation());
  auto sighting = [&](std::initializer_list<RangeBearing> zs) {
    msg::FeatureObservations m{};
    m.robot_id = 1;
    m.seq = ++feature_seq;
    m.stamp = last.t1;
    m.odom_seq = last.seq;
    m.local_pose = last.local_pose;
    for (const RangeBearing& z : zs) m.features[m.n_features++] = {msg::FeatureKind::kRobot, -1, z.range, z.bearing, {0.0009, 0, 0, 1e-4}};
    return m;
  };
  const FusionCounters before = f.counters();
  ASSERT_EQ(f.on_features(sighting({at2})), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().robot_sightings_paired, before.robot_sightings_paired + 1);
  EXPECT_EQ(f.counters().robot_observations_used, before.robot_observations_used + 1);
  const RangeBearing again = observe_point(f.filter().robot_pose(1), f.filter().robot_pose(2).translation());
  f.on_features(sighting({again, again}));
  EXPECT_EQ(f.counters().robot_sightings_paired, before.robot_sightings_paired + 1);
  EXPECT_EQ(f.counters().robot_sightings_unpaired, before.robot_sightings_unpaired + 2);
  f.on_features(sighting({{again.range + 3.0, again.bearing}}));
  EXPECT_EQ(f.counters().robot_sightings_unpaired, before.robot_sightings_unpaired + 3);
  EXPECT_EQ(f.counters().robot_observations_used, before.robot_observations_used + 1);
}

// Issue 14: unread sightings are paired by JCBB among the robots. Robots 2 and 3 stand
// 0.8 m apart, well known; robot 1 is 0.4 m from where its prior puts it. Each sighting
// alone fits either robot (one-by-one pairing left both out); jointly only the right
// pairing fits, and fusing both moves robot 1 to where it is.
TEST(Fusion, UnreadSightingsOfTwoRobotsSideBySideArePairedJointly) {
  FusionConfig c;
  c.robots[1] = {true, {0, 0, 0}, Vec3(0.5, 0.5, 0.01)};
  c.robots[2] = {true, {5, 0, 0}, Vec3(0.01, 0.01, 0.01)};
  c.robots[3] = {true, {5, 0.8, 0}, Vec3(0.01, 0.01, 0.01)};
  Fusion f(c);
  for (const std::uint16_t id : std::initializer_list<std::uint16_t>{1, 2, 3}) {
    msg::OdometryIncrement o{};
    o.robot_id = id;
    o.seq = 1;
    o.delta_cov = {1e-8, 0, 0, 0, 1e-8, 0, 0, 0, 1e-8};
    ASSERT_EQ(f.on_odometry(o), Fusion::Result::kApplied);
  }
  ASSERT_TRUE(f.localized(1) && f.localized(2) && f.localized(3));
  const Pose2 truth{0.3, 0.25, 0};
  msg::FeatureObservations m{};
  m.robot_id = 1;
  m.seq = 1;
  m.odom_seq = 1;
  for (const Vec2& p : {Vec2(5, 0.8), Vec2(5, 0)}) {
    const RangeBearing z = observe_point(truth, p);
    m.features[m.n_features++] = {msg::FeatureKind::kRobot, -1, z.range, z.bearing, {1e-4, 0, 0, 1e-5}};
  }
  ASSERT_EQ(f.on_features(m), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().robot_sightings_unidentified, 2u);
  EXPECT_EQ(f.counters().robot_sightings_paired, 2u);
  EXPECT_EQ(f.counters().robot_observations_used, 2u);
  const Pose2 est = f.filter().robot_pose(1);
  EXPECT_LT(std::hypot(est.x - truth.x, est.y - truth.y), 0.05) << est.x << " " << est.y;
}

TEST(Fusion, RobotWithUnknownStartIsLocalisedByRelocation) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 600);
  Fusion f(config_for(s, /*know_all=*/false));  // robot 2 has no prior
  std::size_t k = 0;
  for (; k < s.messages.size() / 3; ++k) {  // robot 1 maps alone first
    if (std::visit([](const auto& m) { return m.robot_id; }, s.messages[k]) == 1) feed(&f, s.messages[k]);
  }
  EXPECT_FALSE(f.localized(2));
  for (; k < s.messages.size(); ++k) feed(&f, s.messages[k]);
  ASSERT_TRUE(f.localized(2)) << f.counters().rejected.summary();
  EXPECT_LT(position_error(f, s, 1), 0.3);
}

TEST(Fusion, BadDuplicateLateAndMissingMessagesAreCountedNotFatal) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 200);
  Fusion f(config_for(s));
  std::vector<msg::OdometryIncrement> odo;
  std::vector<msg::FeatureObservations> feats;
  for (const auto& m : s.messages) {
    if (auto* o = std::get_if<msg::OdometryIncrement>(&m)) odo.push_back(*o);
    if (auto* ft = std::get_if<msg::FeatureObservations>(&m)) feats.push_back(*ft);
  }
  // Features before their odometry wait; then the odometry releases them.
  EXPECT_EQ(f.on_features(feats[0]), Fusion::Result::kBuffered);
  EXPECT_EQ(f.on_odometry(odo[0]), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().feature_messages_applied, 1u);
  EXPECT_EQ(f.on_features(feats[0]), Fusion::Result::kDuplicate);
  // NaN and a broken covariance are rejected.
  msg::OdometryIncrement bad = odo[1];
  bad.delta.x = std::nan("");
  EXPECT_EQ(f.on_odometry(bad), Fusion::Result::kRejected);
  msg::FeatureObservations badf = feats[1];
  badf.features[0].cov[0] = -1;
  EXPECT_EQ(f.on_features(badf), Fusion::Result::kRejected);
  badf = feats[1];
  badf.n_features = 200;
  EXPECT_EQ(f.on_features(badf), Fusion::Result::kRejected);
  EXPECT_EQ(f.counters().rejected[Reject::kNonFinite], 1u);
  EXPECT_EQ(f.counters().rejected[Reject::kBadCovariance], 1u);
  EXPECT_EQ(f.counters().rejected[Reject::kMalformed], 1u);
  EXPECT_EQ(f.counters().rejected.total(), 3u);
  // A gap in odometry is bridged with the local poses.
  EXPECT_EQ(f.on_odometry(odo[1]), Fusion::Result::kApplied);
  EXPECT_EQ(f.on_odometry(odo[5]), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().odometry_gaps, 1u);
  EXPECT_EQ(f.on_odometry(odo[3]), Fusion::Result::kDuplicate);
  // Features whose odometry is older than the applied one are re-expressed from the current pose...
  EXPECT_EQ(f.on_odometry(odo[6]), Fusion::Result::kApplied);  // seq 7
  EXPECT_EQ(f.on_odometry(odo[7]), Fusion::Result::kApplied);  // seq 8
  ASSERT_EQ(feats[3].odom_seq, 7u);
  EXPECT_EQ(f.on_features(feats[3]), Fusion::Result::kApplied);
  EXPECT_EQ(f.counters().feature_late, 1u);
  // ... unless their odometry was never applied (skipped by the gap) or left the window: stale.
  msg::FeatureObservations ancient = feats[4];
  ancient.odom_seq = 4;  // an increment the gap skipped
  EXPECT_EQ(f.on_features(ancient), Fusion::Result::kRejected);
  EXPECT_EQ(f.counters().feature_stale, 1u);
  const Pose2 est = f.filter().robot_pose(1);
  const Pose2 want = compose(s.starts[0], odo[7].local_pose);
  EXPECT_NEAR(est.x, want.x, 0.1);
}

TEST(Fusion, LateFeaturesGiveTheSameMapAsInOrderOnes) {
  // Deliver every feature message only after the next two odometry increments: the
  // re-expressed observations must give (nearly) the same estimate as in-order delivery.
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 400);
  Fusion in_order(config_for(s)), late(config_for(s));
  std::deque<msg::FeatureObservations> held;
  int odo_since = 0;
  for (const auto& m : s.messages) {
    feed(&in_order, m);
    if (const auto* o = std::get_if<msg::OdometryIncrement>(&m)) {
      late.on_odometry(*o);
      if (++odo_since >= 4) {  // two steps of two robots
        while (!held.empty()) {
          late.on_features(held.front());
          held.pop_front();
        }
        odo_since = 0;
      }
    } else {
      held.push_back(std::get<msg::FeatureObservations>(m));
    }
  }
  EXPECT_GT(late.counters().feature_late, 100u);
  EXPECT_EQ(late.counters().feature_stale, 0u);
  for (int r = 0; r < 2; ++r) {
    EXPECT_LT(position_error(late, s, r), 0.2) << r;
    const Pose2 a = in_order.filter().robot_pose(r + 1), b = late.filter().robot_pose(r + 1);
    EXPECT_LT(std::hypot(a.x - b.x, a.y - b.y), 0.1) << r;
  }
}

TEST(Fusion, SnapshotRestoresTheExactState) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 300);
  Fusion a(config_for(s)), b(config_for(s));
  const std::size_t half = s.messages.size() / 2;
  for (std::size_t k = 0; k < half; ++k) feed(&a, s.messages[k]);
  std::stringstream snap;
  a.save(snap);
  b.load(snap);
  for (std::size_t k = half; k < s.messages.size(); ++k) {
    feed(&a, s.messages[k]);
    feed(&b, s.messages[k]);
  }
  EXPECT_EQ(a.filter().mean(), b.filter().mean());
  EXPECT_EQ(a.filter().covariance(), b.filter().covariance());
}

// The covariance form is configuration, not state: a snapshot loaded into a base configured
// for the Joseph form keeps using it (and one configured for the default keeps the default).
TEST(Fusion, SnapshotKeepsTheConfiguredCovarianceForm) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 100);
  FusionConfig joseph = config_for(s);
  joseph.covariance_update = ccml::CovarianceUpdate::kJoseph;
  Fusion a(config_for(s)), b(joseph);
  EXPECT_EQ(b.filter().covariance_update(), ccml::CovarianceUpdate::kJoseph);
  for (const auto& m : s.messages) feed(&a, m);
  std::stringstream snap;
  a.save(snap);
  b.load(snap);
  EXPECT_EQ(b.filter().covariance_update(), ccml::CovarianceUpdate::kJoseph);
  EXPECT_EQ(a.filter().covariance_update(), ccml::CovarianceUpdate::kSymmetric);
}

TEST(StateStore, CrashAndRestoreLosesNothing) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 300);
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-store-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  Fusion reference(config_for(s));
  for (const auto& m : s.messages) feed(&reference, m);

  const std::size_t crash_at = s.messages.size() * 2 / 3;
  {
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    store.restore(&f);
    for (std::size_t k = 0; k < crash_at; ++k) {
      std::visit([&](const auto& m) { store.append(m, static_cast<Nanos>(k)); }, s.messages[k]);
      feed(&f, s.messages[k]);
      if (k == crash_at / 2) store.maybe_snapshot(f, static_cast<Nanos>(k), true);
    }
  }  // "killed": no final snapshot
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  const RestoreReport rep = store.restore(&f);
  EXPECT_TRUE(rep.snapshot_loaded);
  EXPECT_EQ(rep.torn_records, 0u);
  EXPECT_GT(rep.replayed_odometry + rep.replayed_features, 0u);
  for (std::size_t k = crash_at; k < s.messages.size(); ++k) feed(&f, s.messages[k]);
  EXPECT_EQ(f.filter().mean(), reference.filter().mean());
  EXPECT_EQ(f.filter().covariance(), reference.filter().covariance());
  std::filesystem::remove_all(dir);
}

TEST(StateStore, TornLastRecordIsDetectedAndIgnored) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 50);
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-torn-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  Fusion expect(config_for(s));
  std::uint64_t gen = 0;
  {
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    store.restore(&f);
    gen = store.generation();
    for (std::size_t k = 0; k < 20; ++k) {
      std::visit([&](const auto& m) { store.append(m, 0); }, s.messages[k]);
      if (k < 19) feed(&expect, s.messages[k]);
    }
  }
  const auto log = dir / ("log-" + std::to_string(gen) + ".bin");
  std::filesystem::resize_file(log, std::filesystem::file_size(log) - 7);  // killed mid-write
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  const RestoreReport rep = store.restore(&f);
  EXPECT_EQ(rep.torn_records, 1u);
  EXPECT_EQ(f.filter().mean(), expect.filter().mean());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn::base
