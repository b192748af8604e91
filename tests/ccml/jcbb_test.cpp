// JCBB: correct pairings among clutter and look-alikes, new features left unpaired,
// and the paper's B21b case: a robot joining with tens of metres of uncertainty is
// localised into the map built by another.
#include "basestation/ccml/jcbb.hpp"

#include <gtest/gtest.h>

#include <random>

namespace cairn::ccml {
namespace {

Mat2 R() { return Vec2(0.05 * 0.05, std::pow(1.0 * std::numbers::pi / 180, 2)).asDiagonal(); }

std::vector<Vec2> poles() {
  return {{2, 1}, {5, -2}, {7, 3}, {3, 6}, {9, 0}, {-2, 4}, {6, 7}, {1, -4}, {10, 5}, {-3, -1}};
}

// A map of the poles, built by robot 1 standing at the origin with a precise pose.
CcmlFilter mapped(std::vector<FeatureId>* ids) {
  CcmlFilter f;
  f.add_robot(1, {0, 0, 0}, Vec3(1e-4, 1e-4, 1e-6).asDiagonal());
  for (const Vec2& p : poles()) ids->push_back(f.add_feature(1, observe_point({0, 0, 0}, p), R()));
  return f;
}

TEST(Chi2, QuantilesMatchTables) {
  EXPECT_NEAR(chi2_quantile(0.95, 1), 3.841, 1e-3);
  EXPECT_NEAR(chi2_quantile(0.99, 2), 9.210, 1e-3);
  EXPECT_NEAR(chi2_quantile(0.95, 10), 18.307, 1e-3);
}

TEST(AlignPoints, RecoversARigidMotion) {
  const Pose2 T{3, -2, 0.7};
  std::vector<Vec2> local = {{1, 0}, {0, 2}, {-1, -1}, {4, 3}}, global;
  for (const auto& p : local) global.push_back(transform_point(T, p));
  const Pose2 est = align_points(local, global);
  EXPECT_NEAR(est.x, 3, 1e-9);
  EXPECT_NEAR(est.y, -2, 1e-9);
  EXPECT_NEAR(est.theta, 0.7, 1e-9);
}

TEST(Jcbb, PairsCorrectlyAndLeavesNewFeaturesUnpaired) {
  std::vector<FeatureId> ids;
  CcmlFilter f = mapped(&ids);
  f.add_robot(2, {4.1, 0.9, 0.52}, Vec3(0.04, 0.04, 0.003).asDiagonal());
  const Pose2 truth{4, 1, 0.5};
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  std::vector<RangeBearing> zs;
  std::vector<int> expected;  // index into poles, or -1
  for (int i : {0, 1, 2, 4, 6}) {
    RangeBearing z = observe_point(truth, poles()[i]);
    z.range += 0.05 * g(rng);
    z.bearing += 0.017 * g(rng);
    zs.push_back(z);
    expected.push_back(i);
  }
  zs.push_back(observe_point(truth, {12, -6}));  // not in the map
  expected.push_back(-1);
  const std::vector<Mat2> Rs(zs.size(), R());
  const JcbbResult r = jcbb(f, 2, zs, Rs, ids);
  EXPECT_FALSE(r.relocation_mode);
  EXPECT_EQ(r.pairings, 5);
  for (std::size_t i = 0; i < zs.size(); ++i) {
    if (expected[i] < 0) {
      EXPECT_FALSE(r.pairing[i].has_value());
    } else {
      ASSERT_TRUE(r.pairing[i].has_value()) << i;
      EXPECT_EQ(*r.pairing[i], ids[expected[i]]) << i;
    }
  }
  EXPECT_LE(r.joint_nis, chi2_quantile(0.99, 10));
}

TEST(Jcbb, JointTestRejectsIndividuallyPlausibleButInconsistentPairs) {
  // Two poles 0.6 m apart and a moderately uncertain robot: each observation is
  // individually compatible with both poles, only the joint test tells the right pairing.
  CcmlFilter f;
  f.add_robot(1, {0, 0, 0}, Vec3(1e-6, 1e-6, 1e-8).asDiagonal());
  const Vec2 a{5, 0.3}, b{5, -0.3}, c{3, 4};
  const FeatureId ia = f.add_feature_prior(a, Mat2::Identity() * 1e-4);
  const FeatureId ib = f.add_feature_prior(b, Mat2::Identity() * 1e-4);
  const FeatureId ic = f.add_feature_prior(c, Mat2::Identity() * 1e-4);
  f.add_robot(2, {0.0, 0.0, 0.0}, Vec3(0.09, 0.09, 0.0025).asDiagonal());
  const Pose2 truth{0.0, 0.25, 0.0};
  std::vector<RangeBearing> zs = {observe_point(truth, a), observe_point(truth, b), observe_point(truth, c)};
  std::vector<Mat2> Rs(3, R());
  const FeatureId cand[] = {ia, ib, ic};
  const JcbbResult r = jcbb(f, 2, zs, Rs, cand);
  ASSERT_EQ(r.pairings, 3);
  EXPECT_EQ(*r.pairing[0], ia);
  EXPECT_EQ(*r.pairing[1], ib);
  EXPECT_EQ(*r.pairing[2], ic);
}

TEST(Jcbb, RobotJoiningWithTensOfMetresOfUncertaintyIsLocalisedIntoTheMap) {
  // The paper's B21a/B21b experiment: robot 1 has mapped the poles; robot 2 joins with
  // 30 m position and ±180° heading uncertainty. JCBB (location-independent) finds the
  // pairing; the iterated update seeded with the aligned pose localises robot 2.
  std::vector<FeatureId> ids;
  CcmlFilter f = mapped(&ids);
  const Pose2 truth{6.5, 2.0, 2.4};
  f.add_robot(2, {0, 0, 0}, Vec3(900, 900, 10).asDiagonal());
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  std::vector<RangeBearing> zs;
  std::vector<int> truth_idx;
  for (std::size_t i = 0; i < poles().size(); ++i) {
    RangeBearing z = observe_point(truth, poles()[i]);
    if (z.range > 7.0) continue;
    z.range += 0.05 * g(rng);
    z.bearing += 0.017 * g(rng);
    zs.push_back(z);
    truth_idx.push_back(static_cast<int>(i));
  }
  ASSERT_GE(zs.size(), 4u);
  const std::vector<Mat2> Rs(zs.size(), R());
  const JcbbResult r = jcbb(f, 2, zs, Rs, ids);
  EXPECT_TRUE(r.relocation_mode);
  EXPECT_FALSE(r.budget_exhausted);
  ASSERT_EQ(r.pairings, static_cast<int>(zs.size()));
  for (std::size_t i = 0; i < zs.size(); ++i) EXPECT_EQ(*r.pairing[i], ids[truth_idx[i]]);
  ASSERT_TRUE(r.aligned_pose.has_value());
  EXPECT_FALSE(r.ambiguous) << "rival with " << r.rival_pairings << " pairings";

  std::vector<Measurement> ms;
  for (std::size_t i = 0; i < zs.size(); ++i) ms.push_back({2, Measurement::Target::kFeature, *r.pairing[i], zs[i], Rs[i]});
  const CcmlFilter::Seed seed{2, *r.aligned_pose};
  ASSERT_TRUE(f.update(ms, 10, &seed).applied);
  const Pose2 est = f.robot_pose(2);
  EXPECT_LT(std::hypot(est.x - truth.x, est.y - truth.y), 0.15) << est.x << "," << est.y;
  EXPECT_LT(std::abs(normalize_angle(est.theta - truth.theta)), 0.03);
  EXPECT_LT(std::sqrt(f.robot_cov(2)(0, 0)), 0.2);  // from 30 m to decimetres
  EXPECT_GT(f.min_eigenvalue(), 0.0);
}

// Issue 16 (f): four landmarks on a square fit the observations at four poses (rotations by
// 90°) equally well. Relocation must see the rival hypotheses and say it is ambiguous.
TEST(Jcbb, SymmetricLayoutMakesRelocationAmbiguous) {
  CcmlFilter f;
  std::vector<FeatureId> ids;
  const std::vector<Vec2> square{{4, 4}, {-4, 4}, {-4, -4}, {4, -4}};
  for (const Vec2& p : square) ids.push_back(f.add_feature_prior(p, Mat2::Identity() * 1e-4));
  const Pose2 truth{1.0, 0.5, 0.3};
  f.add_robot(2, {0, 0, 0}, Vec3(900, 900, 10).asDiagonal());
  std::vector<RangeBearing> zs;
  for (const Vec2& p : square) zs.push_back(observe_point(truth, p));
  const std::vector<Mat2> Rs(zs.size(), R());
  const JcbbResult r = jcbb(f, 2, zs, Rs, ids);
  ASSERT_TRUE(r.relocation_mode);
  EXPECT_FALSE(r.budget_exhausted);
  EXPECT_EQ(r.pairings, 4);
  EXPECT_EQ(r.rival_pairings, 4);
  EXPECT_TRUE(r.ambiguous);
  // Break the symmetry with a fifth landmark seen too: no longer ambiguous.
  ids.push_back(f.add_feature_prior({6, 1}, Mat2::Identity() * 1e-4));
  zs.push_back(observe_point(truth, {6, 1}));
  const std::vector<Mat2> Rs5(zs.size(), R());
  const JcbbResult r5 = jcbb(f, 2, zs, Rs5, ids);
  EXPECT_EQ(r5.pairings, 5);
  EXPECT_FALSE(r5.ambiguous) << r5.rival_pairings;
}

// Issue 14: sightings of robots whose marker was not read. Robots 2 and 3 stand 0.8 m apart
// and are well known; the observer, robot 1, is 0.4 m from where the filter has it. Each
// sighting alone fits either robot, so one-by-one pairing with a uniqueness test pairs
// neither; jointly only the right pairing keeps the one offset both sightings share.
struct TwoRobotsSideBySide {
  CcmlFilter f;
  Pose2 truth{0.3, 0.25, 0.0};
  Vec2 at2{5, 0}, at3{5, 0.8};
  std::vector<RobotId> robots{2, 3};
  TwoRobotsSideBySide() {
    f.add_robot(1, {0, 0, 0}, Vec3(0.25, 0.25, 1e-4).asDiagonal());
    f.add_robot(2, {at2.x(), at2.y(), 0}, Vec3(1e-4, 1e-4, 1e-4).asDiagonal());
    f.add_robot(3, {at3.x(), at3.y(), 0}, Vec3(1e-4, 1e-4, 1e-4).asDiagonal());
  }
  Measurement sighting(const Vec2& p, RobotId target) const {
    return {1, Measurement::Target::kRobot, target, observe_point(truth, p), R()};
  }
};

TEST(JcbbRobots, TwoRobotsSideBySideArePairedJointlyWhereOneByOneCannot) {
  const TwoRobotsSideBySide w;
  // The premise: each sighting passes the individual gate for both robots.
  const double gate = chi2_quantile(0.99, 2);
  for (const Vec2& p : {w.at2, w.at3}) {
    for (RobotId r : w.robots) EXPECT_LT(w.f.innovation(w.sighting(p, r)).nis(), gate) << r;
  }
  const std::vector<RangeBearing> zs{observe_point(w.truth, w.at3), observe_point(w.truth, w.at2)};
  const std::vector<Mat2> Rs(2, R());
  const JcbbResult r = jcbb_robots(w.f, 1, zs, Rs, w.robots);
  EXPECT_FALSE(r.budget_exhausted);
  EXPECT_FALSE(r.ambiguous);
  ASSERT_EQ(r.pairings, 2);
  EXPECT_EQ(r.pairing[0], std::optional<FeatureId>(3));
  EXPECT_EQ(r.pairing[1], std::optional<FeatureId>(2));
}

TEST(JcbbRobots, ASightingTwoRobotsExplainOrTwoSightingsOfOneAreLeftOut) {
  const TwoRobotsSideBySide w;
  const std::vector<Mat2> R1(1, R()), R2(2, R());
  // One sighting, either robot: contested.
  const std::vector<RangeBearing> one{observe_point(w.truth, w.at2)};
  const JcbbResult a = jcbb_robots(w.f, 1, one, R1, w.robots);
  EXPECT_TRUE(a.ambiguous);
  EXPECT_FALSE(a.pairing[0]);
  // With robot 3 not a candidate, the same sighting is robot 2's.
  const std::vector<RobotId> only2{2};
  const JcbbResult b = jcbb_robots(w.f, 1, one, R1, only2);
  EXPECT_FALSE(b.ambiguous);
  EXPECT_EQ(b.pairing[0], std::optional<FeatureId>(2));
  // Two sightings, one robot that explains them: neither.
  const std::vector<RangeBearing> twice{one[0], one[0]};
  const JcbbResult c = jcbb_robots(w.f, 1, twice, R2, only2);
  EXPECT_TRUE(c.ambiguous);
  EXPECT_FALSE(c.pairing[0]);
  EXPECT_FALSE(c.pairing[1]);
  // A sighting where no robot is: unpaired, and nothing contested.
  const std::vector<RangeBearing> nowhere{observe_point(w.truth, {5, -4})};
  const JcbbResult d = jcbb_robots(w.f, 1, nowhere, R1, w.robots);
  EXPECT_FALSE(d.ambiguous);
  EXPECT_FALSE(d.pairing[0]);
  EXPECT_EQ(d.pairings, 0);
}

}  // namespace
}  // namespace cairn::ccml
