#include "common/se2.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <random>

namespace cairn {
namespace {

// Central differences of f: R^n -> R^m at x, with angle outputs wrapped.
template <int M, int N>
Eigen::Matrix<double, M, N> numeric_jacobian(const std::function<Eigen::Matrix<double, M, 1>(const Eigen::Matrix<double, N, 1>&)>& f,
                                            const Eigen::Matrix<double, N, 1>& x, int angle_row = -1) {
  Eigen::Matrix<double, M, N> j;
  const double h = 1e-6;
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> xp = x, xm = x;
    xp(k) += h;
    xm(k) -= h;
    Eigen::Matrix<double, M, 1> d = f(xp) - f(xm);
    if (angle_row >= 0) d(angle_row) = normalize_angle(d(angle_row));
    j.col(k) = d / (2 * h);
  }
  return j;
}

class Se2Test : public ::testing::Test {
 protected:
  Pose2 random_pose() { return {u_(rng_) * 10, u_(rng_) * 10, u_(rng_) * 3.1}; }
  Vec2 random_point() { return {u_(rng_) * 10, u_(rng_) * 10}; }
  std::mt19937 rng_{42};
  std::uniform_real_distribution<double> u_{-1.0, 1.0};
};

TEST(NormalizeAngle, WrapsIntoHalfOpenRange) {
  EXPECT_NEAR(normalize_angle(0.5), 0.5, 1e-15);
  EXPECT_NEAR(normalize_angle(3 * std::numbers::pi), -std::numbers::pi, 1e-12);
  EXPECT_NEAR(normalize_angle(-3 * std::numbers::pi), -std::numbers::pi, 1e-12);
  EXPECT_NEAR(normalize_angle(2 * std::numbers::pi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(normalize_angle(-2 * std::numbers::pi - 0.1), -0.1, 1e-12);
  EXPECT_NEAR(normalize_angle(1e6), std::remainder(1e6, 2 * std::numbers::pi), 1e-6);
  for (double a = -50; a < 50; a += 0.37) {
    const double n = normalize_angle(a);
    EXPECT_GE(n, -std::numbers::pi);
    EXPECT_LT(n, std::numbers::pi);
    EXPECT_NEAR(std::sin(n), std::sin(a), 1e-9);
    EXPECT_NEAR(std::cos(n), std::cos(a), 1e-9);
  }
}

TEST_F(Se2Test, ComposeInverseBetweenAreConsistent) {
  for (int i = 0; i < 200; ++i) {
    const Pose2 a = random_pose(), b = random_pose();
    const Pose2 id = compose(a, inverse(a));
    EXPECT_NEAR(id.x, 0, 1e-12);
    EXPECT_NEAR(id.y, 0, 1e-12);
    EXPECT_NEAR(id.theta, 0, 1e-12);
    const Pose2 rel = between(a, b);
    const Pose2 back = compose(a, rel);
    EXPECT_NEAR(back.x, b.x, 1e-9);
    EXPECT_NEAR(back.y, b.y, 1e-9);
    EXPECT_NEAR(normalize_angle(back.theta - b.theta), 0, 1e-12);
    const Pose2 rel2 = compose(inverse(a), b);
    EXPECT_NEAR(rel.x, rel2.x, 1e-9);
    EXPECT_NEAR(rel.y, rel2.y, 1e-9);
  }
}

TEST(Se2, KnownValues) {
  const Pose2 a{1, 2, std::numbers::pi / 2};
  const Pose2 c = compose(a, {1, 0, 0});
  EXPECT_NEAR(c.x, 1, 1e-12);
  EXPECT_NEAR(c.y, 3, 1e-12);
  const Vec2 p = transform_point(a, {0, 1});
  EXPECT_NEAR(p.x(), 0, 1e-12);
  EXPECT_NEAR(p.y(), 2, 1e-12);
  const RangeBearing z = observe_point({0, 0, std::numbers::pi / 2}, {1, 1});
  EXPECT_NEAR(z.range, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(z.bearing, -std::numbers::pi / 4, 1e-12);
}

TEST_F(Se2Test, ComposeJacobiansMatchNumeric) {
  for (int i = 0; i < 50; ++i) {
    const Pose2 a = random_pose(), b = random_pose();
    Mat3 ja, jb;
    compose_jacobians(a, b, &ja, &jb);
    const auto na = numeric_jacobian<3, 3>([&](const Vec3& v) { return compose(Pose2::from_vector(v), b).vector(); }, a.vector(), 2);
    const auto nb = numeric_jacobian<3, 3>([&](const Vec3& v) { return compose(a, Pose2::from_vector(v)).vector(); }, b.vector(), 2);
    EXPECT_TRUE(ja.isApprox(na, 1e-6)) << ja << "\n" << na;
    EXPECT_TRUE(jb.isApprox(nb, 1e-6)) << jb << "\n" << nb;
  }
}

TEST_F(Se2Test, InverseAndBetweenJacobiansMatchNumeric) {
  for (int i = 0; i < 50; ++i) {
    const Pose2 a = random_pose(), b = random_pose();
    const auto ni = numeric_jacobian<3, 3>([](const Vec3& v) { return inverse(Pose2::from_vector(v)).vector(); }, a.vector(), 2);
    EXPECT_TRUE(inverse_jacobian(a).isApprox(ni, 1e-6));
    Mat3 ja, jb;
    between_jacobians(a, b, &ja, &jb);
    const auto na = numeric_jacobian<3, 3>([&](const Vec3& v) { return between(Pose2::from_vector(v), b).vector(); }, a.vector(), 2);
    const auto nb = numeric_jacobian<3, 3>([&](const Vec3& v) { return between(a, Pose2::from_vector(v)).vector(); }, b.vector(), 2);
    EXPECT_TRUE(ja.isApprox(na, 1e-6));
    EXPECT_TRUE(jb.isApprox(nb, 1e-6));
  }
}

TEST_F(Se2Test, PointTransformJacobiansMatchNumeric) {
  for (int i = 0; i < 50; ++i) {
    const Pose2 a = random_pose();
    const Vec2 p = random_point();
    Mat23 jp;
    Mat2 jq;
    transform_point_jacobians(a, p, &jp, &jq);
    EXPECT_TRUE(jp.isApprox((numeric_jacobian<2, 3>([&](const Vec3& v) { return transform_point(Pose2::from_vector(v), p); }, a.vector())), 1e-6));
    EXPECT_TRUE(jq.isApprox((numeric_jacobian<2, 2>([&](const Vec2& q) { return transform_point(a, q); }, p)), 1e-6));
    inverse_transform_point_jacobians(a, p, &jp, &jq);
    EXPECT_TRUE(jp.isApprox((numeric_jacobian<2, 3>([&](const Vec3& v) { return inverse_transform_point(Pose2::from_vector(v), p); }, a.vector())), 1e-6));
    EXPECT_TRUE(jq.isApprox((numeric_jacobian<2, 2>([&](const Vec2& q) { return inverse_transform_point(a, q); }, p)), 1e-6));
    EXPECT_TRUE(inverse_transform_point(a, transform_point(a, p)).isApprox(p, 1e-9));
  }
}

TEST_F(Se2Test, RangeBearingJacobiansMatchNumeric) {
  for (int i = 0; i < 50; ++i) {
    const Pose2 a = random_pose();
    const Vec2 p = random_point() + Vec2(25, 0);  // keep away from range 0
    Mat23 hp;
    Mat2 hq;
    observe_point_jacobians(a, p, &hp, &hq);
    auto obs_pose = [&](const Vec3& v) { return observe_point(Pose2::from_vector(v), p).vector(); };
    auto obs_point = [&](const Vec2& q) { return observe_point(a, q).vector(); };
    EXPECT_TRUE(hp.isApprox((numeric_jacobian<2, 3>(obs_pose, a.vector(), 1)), 1e-5));
    EXPECT_TRUE(hq.isApprox((numeric_jacobian<2, 2>(obs_point, p, 1)), 1e-5));

    const RangeBearing z = observe_point(a, p);
    EXPECT_TRUE(point_from_observation(a, z).isApprox(p, 1e-9));
    Mat23 gp;
    Mat2 gz;
    point_from_observation_jacobians(a, z, &gp, &gz);
    EXPECT_TRUE(gp.isApprox((numeric_jacobian<2, 3>([&](const Vec3& v) { return point_from_observation(Pose2::from_vector(v), z); }, a.vector())), 1e-6));
    EXPECT_TRUE(gz.isApprox((numeric_jacobian<2, 2>([&](const Vec2& v) { return point_from_observation(a, {v.x(), v.y()}); }, z.vector())), 1e-6));
  }
}

}  // namespace
}  // namespace cairn
