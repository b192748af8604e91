// The CCML filter against a dense textbook EKF: the blockwise prediction, update
// (both covariance forms: the symmetric rank update and the Joseph form without H) and
// feature augmentation must give the same numbers.
#include "basestation/ccml/filter.hpp"

#include <gtest/gtest.h>

#include <random>

namespace cairn::ccml {
namespace {

Mat2 meas_cov() {
  Mat2 R = Mat2::Zero();
  R(0, 0) = 0.04;
  R(1, 1) = std::pow(2.0 * std::numbers::pi / 180.0, 2);
  return R;
}

// A filter with two robots and three features, with non-trivial correlations.
CcmlFilter make_filter() {
  CcmlFilter f(4);  // small capacity: exercises growth
  f.add_robot(1, {0, 0, 0.1}, Vec3(0.05, 0.04, 0.01).asDiagonal());
  f.add_robot(2, {5, 1, -0.5}, Vec3(0.2, 0.3, 0.02).asDiagonal());
  f.add_feature(1, {4.0, 0.3}, meas_cov());
  f.add_feature(2, {3.0, -0.7}, meas_cov());
  f.add_feature(1, {6.0, 1.1}, meas_cov());
  f.predict(1, {0.5, 0.02, 0.05}, Vec3(0.01, 0.005, 0.002).asDiagonal());
  return f;
}

TEST(CcmlFilter, PredictMatchesDenseJacobianForm) {
  CcmlFilter f = make_filter();
  const Eigen::MatrixXd P0 = f.covariance();
  const Pose2 before = f.robot_pose(2);
  const Pose2 delta{0.4, -0.1, 0.2};
  const Mat3 Q = Vec3(0.02, 0.01, 0.003).asDiagonal();
  f.predict(2, delta, Q);
  const int o = f.robot_offset(2);
  const auto n = static_cast<Eigen::Index>(f.dimension());
  Eigen::MatrixXd F = Eigen::MatrixXd::Identity(n, n);
  Mat3 Fr, G;
  compose_jacobians(before, delta, &Fr, &G);
  F.block<3, 3>(o, o) = Fr;
  Eigen::MatrixXd Gf = Eigen::MatrixXd::Zero(n, 3);
  Gf.middleRows<3>(o) = G;
  const Eigen::MatrixXd expected = F * P0 * F.transpose() + Gf * Q * Gf.transpose();
  EXPECT_TRUE(f.covariance().isApprox(expected, 1e-12));
  const Pose2 after = f.robot_pose(2), want = compose(before, delta);
  EXPECT_NEAR(after.x, want.x, 1e-12);
  EXPECT_NEAR(after.theta, want.theta, 1e-12);
}

class CcmlUpdateForm : public ::testing::TestWithParam<CovarianceUpdate> {};

TEST_P(CcmlUpdateForm, UpdateMatchesDenseJosephEkf) {
  CcmlFilter f = make_filter();
  f.set_covariance_update(GetParam());
  const Eigen::VectorXd x0 = f.mean();
  const Eigen::MatrixXd P0 = f.covariance();
  const auto n = static_cast<Eigen::Index>(f.dimension());
  const auto fids = f.feature_ids();
  std::vector<Measurement> ms = {
      {1, Measurement::Target::kFeature, fids[0], {4.1, 0.28}, meas_cov()},
      {2, Measurement::Target::kFeature, fids[2], {1.3, 0.9}, meas_cov()},
      {1, Measurement::Target::kRobot, 2, {5.0, 0.15}, meas_cov()},
  };
  // Dense reference: H (2m x n), S, K, Joseph.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6, n);
  Eigen::VectorXd nu(6);
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(6, 6);
  for (int k = 0; k < 3; ++k) {
    const int o = f.robot_offset(ms[k].observer);
    const int t = ms[k].target_kind == Measurement::Target::kFeature ? f.feature_offset(ms[k].target) : f.robot_offset(ms[k].target);
    const Pose2 pose{x0(o), x0(o + 1), x0(o + 2)};
    const Vec2 p = x0.segment<2>(t);
    Mat23 ho;
    Mat2 ht;
    observe_point_jacobians(pose, p, &ho, &ht);
    H.block<2, 3>(2 * k, o) = ho;
    H.block<2, 2>(2 * k, t) += ht;
    const RangeBearing h = observe_point(pose, p);
    nu(2 * k) = ms[k].z.range - h.range;
    nu(2 * k + 1) = normalize_angle(ms[k].z.bearing - h.bearing);
    R.block<2, 2>(2 * k, 2 * k) = ms[k].R;
  }
  const Eigen::MatrixXd S = H * P0 * H.transpose() + R;
  const Eigen::MatrixXd K = P0 * H.transpose() * S.inverse();
  const Eigen::MatrixXd IKH = Eigen::MatrixXd::Identity(n, n) - K * H;
  const Eigen::MatrixXd P_expected = IKH * P0 * IKH.transpose() + K * R * K.transpose();
  Eigen::VectorXd x_expected = x0 + K * nu;

  Eigen::VectorXd nu_joint;
  Eigen::MatrixXd S_joint;
  f.joint_innovation(ms, &nu_joint, &S_joint);
  EXPECT_TRUE(S_joint.isApprox(S, 1e-10));
  EXPECT_TRUE(nu_joint.isApprox(nu, 1e-10));

  const UpdateResult u = f.update(ms);
  ASSERT_TRUE(u.applied);
  EXPECT_EQ(u.dof, 6);
  EXPECT_NEAR(u.nis, nu.dot(S.inverse() * nu), 1e-8);
  EXPECT_TRUE(f.covariance().isApprox(P_expected, 1e-9));
  for (int r : {f.robot_offset(1), f.robot_offset(2)}) x_expected(r + 2) = normalize_angle(x_expected(r + 2));
  EXPECT_TRUE(f.mean().isApprox(x_expected, 1e-10));
  EXPECT_LT(f.max_asymmetry(), 1e-15);
  EXPECT_GT(f.min_eigenvalue(), 0.0);
}


TEST(CcmlFilter, SymmetricUpdateIsTheDefault) {
  EXPECT_EQ(CcmlFilter().covariance_update(), CovarianceUpdate::kSymmetric);
}

// A long random run: the symmetric form keeps P exactly symmetric (it mirrors one
// triangle), stays positive definite, and agrees with the Joseph form step for step.
TEST(CcmlFilter, BothCovarianceFormsAgreeOverALongRun) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  CcmlFilter sym, jos;
  jos.set_covariance_update(CovarianceUpdate::kJoseph);
  for (CcmlFilter* f : {&sym, &jos}) {
    f->add_robot(1, {0, 0, 0}, Vec3(0.01, 0.01, 0.001).asDiagonal());
    f->add_robot(2, {1, 1, 0.3}, Vec3(0.04, 0.04, 0.004).asDiagonal());
  }
  std::vector<Vec2> landmarks;
  for (int i = 0; i < 25; ++i) landmarks.emplace_back(g(rng) * 8, g(rng) * 8);
  std::vector<FeatureId> ids(landmarks.size(), 0);
  Pose2 truth[2] = {{0, 0, 0}, {1, 1, 0.3}};
  for (int step = 0; step < 400; ++step) {
    std::vector<Measurement> ms;
    for (RobotId r : {1u, 2u}) {
      const Pose2 d{0.15, 0, 0.06 * g(rng)};
      truth[r - 1] = compose(truth[r - 1], d);
      for (CcmlFilter* f : {&sym, &jos}) f->predict(r, d, Vec3(1e-4, 1e-4, 1e-5).asDiagonal());
      for (std::size_t i = 0; i < landmarks.size(); ++i) {
        RangeBearing z = observe_point(truth[r - 1], landmarks[i]);
        if (z.range > 6 || z.range < 0.3) continue;
        z.range += 0.05 * g(rng);
        z.bearing += 0.01 * g(rng);
        const Mat2 R = Vec2(0.0025, 1e-4).asDiagonal();
        if (!ids[i]) {
          ids[i] = sym.add_feature(r, z, R);
          ASSERT_EQ(jos.add_feature(r, z, R), ids[i]);
        } else {
          ms.push_back({r, Measurement::Target::kFeature, ids[i], z, R});
        }
      }
    }
    const UpdateResult a = sym.update(ms), b = jos.update(ms);
    ASSERT_EQ(a.applied, b.applied);
    ASSERT_EQ(sym.max_asymmetry(), 0.0) << "step " << step;
  }
  const Eigen::MatrixXd Ps = sym.covariance(), Pj = jos.covariance();
  EXPECT_LT((Ps - Pj).cwiseAbs().maxCoeff(), 1e-9 * Pj.cwiseAbs().maxCoeff());
  EXPECT_LT((sym.mean() - jos.mean()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(sym.min_eigenvalue(), 0.0);
  EXPECT_GE(sym.feature_count(), 10u);  // the run exercised a real map (12 of the 25 points)
}

TEST(CcmlFilter, FeatureAugmentationMatchesDense) {
  CcmlFilter f = make_filter();
  const Eigen::MatrixXd P0 = f.covariance();
  const Pose2 pose = f.robot_pose(2);
  const int o = f.robot_offset(2);
  const RangeBearing z{2.5, 0.4};
  const FeatureId id = f.add_feature(2, z, meas_cov());
  const auto n0 = P0.rows();
  Mat23 gp;
  Mat2 gz;
  point_from_observation_jacobians(pose, z, &gp, &gz);
  Eigen::MatrixXd Gx = Eigen::MatrixXd::Zero(2, n0);
  Gx.middleCols<3>(o) = gp;
  const Eigen::MatrixXd cross = Gx * P0;
  const int fo = f.feature_offset(id);
  EXPECT_EQ(fo, n0);
  EXPECT_TRUE(f.covariance().block(fo, 0, 2, n0).isApprox(cross, 1e-12));
  EXPECT_TRUE(f.feature_cov(id).isApprox(Gx * P0 * Gx.transpose() + gz * meas_cov() * gz.transpose(), 1e-12));
  EXPECT_TRUE(f.feature(id).isApprox(point_from_observation(pose, z), 1e-12));
}

TEST(CcmlFilter, RemovingARobotMarginalisesIt) {
  CcmlFilter f = make_filter();
  const Eigen::MatrixXd P0 = f.covariance();
  const int o = f.robot_offset(1);
  const auto fids = f.feature_ids();
  const Mat2 f2_before = f.feature_cov(fids[1]);
  f.remove_robot(1);
  EXPECT_FALSE(f.has_robot(1));
  EXPECT_EQ(f.dimension(), static_cast<std::size_t>(P0.rows() - 3));
  EXPECT_TRUE(f.feature_cov(fids[1]).isApprox(f2_before, 1e-15));
  EXPECT_EQ(f.robot_offset(2), o);  // robot 2 moved into robot 1's slot
  EXPECT_THROW(f.robot_pose(1), std::out_of_range);
}

TEST(CcmlFilter, StaysSymmetricPositiveDefiniteOverManyRandomSteps) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0, 1);
  CcmlFilter f;
  f.add_robot(1, {0, 0, 0}, Vec3(0.01, 0.01, 0.001).asDiagonal());
  std::vector<Vec2> landmarks;
  for (int i = 0; i < 30; ++i) landmarks.emplace_back(g(rng) * 10, g(rng) * 10);
  std::vector<FeatureId> ids(landmarks.size(), 0);
  Pose2 truth{0, 0, 0};
  for (int step = 0; step < 400; ++step) {
    const Pose2 d{0.2, 0, 0.05 * g(rng)};
    truth = compose(truth, d);
    f.predict(1, d, Vec3(1e-4, 1e-4, 1e-5).asDiagonal());
    std::vector<Measurement> ms;
    for (std::size_t i = 0; i < landmarks.size(); ++i) {
      RangeBearing z = observe_point(truth, landmarks[i]);
      if (z.range > 8 || z.range < 0.3) continue;
      z.range += 0.05 * g(rng);
      z.bearing += 0.01 * g(rng);
      Mat2 R = Vec2(0.0025, 1e-4).asDiagonal();
      if (!ids[i]) {
        ids[i] = f.add_feature(1, z, R);
      } else {
        ms.push_back({1, Measurement::Target::kFeature, ids[i], z, R});
      }
    }
    f.update(ms);
  }
  EXPECT_LT(f.max_asymmetry(), 1e-12);
  EXPECT_GT(f.min_eigenvalue(), 0.0);
  const Pose2 est = f.robot_pose(1);
  EXPECT_LT(std::hypot(est.x - truth.x, est.y - truth.y), 1.0);
}

TEST(CcmlFilter, RejectsDuplicatesAndUnknowns) {
  CcmlFilter f;
  f.add_robot(1, {}, Mat3::Identity());
  EXPECT_THROW(f.add_robot(1, {}, Mat3::Identity()), std::invalid_argument);
  EXPECT_THROW(f.predict(9, {}, Mat3::Identity()), std::out_of_range);
  EXPECT_THROW(f.feature(3), std::out_of_range);
  EXPECT_FALSE(f.update({}).applied);
}

// Issue 16 (b): a prediction or update that would make the joint state non-finite is
// refused and leaves the state exactly as it was (Eigen's LLT does not notice NaN).
TEST(CcmlFilter, NonFinitePredictionIsRefusedAndStateUnchanged) {
  CcmlFilter f = make_filter();
  const Eigen::VectorXd x0 = f.mean();
  const Eigen::MatrixXd P0 = f.covariance();
  EXPECT_FALSE(f.predict(1, {1e308, 1e308, 0.0}, Vec3(1e308, 1e308, 1.0).asDiagonal()));
  EXPECT_FALSE(f.predict(2, {0.1, 0, std::nan("")}, Mat3::Identity() * 1e-4));
  EXPECT_EQ(f.mean(), x0);
  EXPECT_EQ(f.covariance(), P0);
  EXPECT_TRUE(f.predict(1, {0.1, 0, 0}, Mat3::Identity() * 1e-4));  // a sane one still goes through
}

TEST_P(CcmlUpdateForm, NonFiniteUpdateIsRefusedAndStateUnchanged) {
  CcmlFilter f = make_filter();
  f.set_covariance_update(GetParam());
  const Eigen::VectorXd x0 = f.mean();
  const Eigen::MatrixXd P0 = f.covariance();
  const FeatureId feat = f.feature_ids().front();
  Measurement inf_noise{1, Measurement::Target::kFeature, feat, {4.0, 0.3}, Mat2::Identity() * std::numeric_limits<double>::infinity()};
  Measurement nan_range{1, Measurement::Target::kFeature, feat, {std::nan(""), 0.3}, meas_cov()};
  for (const Measurement& m : {inf_noise, nan_range}) {
    const UpdateResult r = f.update(std::span<const Measurement>(&m, 1));
    EXPECT_FALSE(r.applied);
    EXPECT_TRUE(r.refused);
    EXPECT_TRUE(f.mean().allFinite());
    EXPECT_EQ(f.mean(), x0);
    EXPECT_EQ(f.covariance(), P0);
  }
}


// The path relocation takes in production (fusion.cpp: update(ms, 15, &seed)): an iterated
// update from a seeded linearisation point. Both covariance forms give the same posterior
// (they share K, S and P Hᵀ of the last iterate), exactly symmetric for the symmetric one.
TEST(CcmlFilter, IteratedSeededUpdateAgreesBetweenForms) {
  CcmlFilter sym = make_filter();
  CcmlFilter jos = make_filter();
  jos.set_covariance_update(CovarianceUpdate::kJoseph);
  const auto fids = sym.feature_ids();
  const std::vector<Measurement> ms = {
      {2, Measurement::Target::kFeature, fids[0], {5.2, 2.9}, meas_cov()},
      {2, Measurement::Target::kFeature, fids[1], {3.1, -0.6}, meas_cov()},
      {1, Measurement::Target::kRobot, 2, {5.0, 0.15}, meas_cov()},
  };
  const CcmlFilter::Seed seed{2, {5.3, 0.8, -0.45}};
  const UpdateResult a = sym.update(ms, 15, &seed), b = jos.update(ms, 15, &seed);
  ASSERT_TRUE(a.applied);
  ASSERT_TRUE(b.applied);
  EXPECT_LT((sym.covariance() - jos.covariance()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((sym.mean() - jos.mean()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(sym.max_asymmetry(), 0.0);
  EXPECT_GT(sym.min_eigenvalue(), 0.0);
  // And it moved: the iterate is not the prior.
  EXPECT_GT((sym.mean() - make_filter().mean()).norm(), 1e-3);
}

INSTANTIATE_TEST_SUITE_P(BothForms, CcmlUpdateForm, ::testing::Values(CovarianceUpdate::kSymmetric, CovarianceUpdate::kJoseph),
                         [](const auto& param_info) { return param_info.param == CovarianceUpdate::kSymmetric ? "Symmetric" : "Joseph"; });

}  // namespace
}  // namespace cairn::ccml
