// SE(2) geometry on Eigen fixed-size types: poses, composition, inverse,
// relative pose, point transforms and range-bearing observations, each with
// the analytic Jacobians the EKF and the scan matcher need.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

namespace cairn {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Mat23 = Eigen::Matrix<double, 2, 3>;
using Mat32 = Eigen::Matrix<double, 3, 2>;

/// Wraps an angle into [-pi, pi).
inline double normalize_angle(double a) {
  constexpr double two_pi = 2.0 * std::numbers::pi;
  if (a >= -std::numbers::pi && a < std::numbers::pi) return a;
  a = std::fmod(a + std::numbers::pi, two_pi);
  if (a < 0.0) a += two_pi;
  return a - std::numbers::pi;
}

/// A rigid 2D transform / robot pose: position (x, y) in metres, heading theta in radians.
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  static Pose2 from_vector(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
  Vec3 vector() const { return {x, y, theta}; }
  Vec2 translation() const { return {x, y}; }
  friend bool operator==(const Pose2&, const Pose2&) = default;  // exact, member by member
  Mat2 rotation() const {
    const double c = std::cos(theta), s = std::sin(theta);
    Mat2 r;
    r << c, -s, s, c;
    return r;
  }
};

/// a ⊕ b: b expressed in a's frame, returned in the frame a is expressed in.
inline Pose2 compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, normalize_angle(a.theta + b.theta)};
}

/// ⊖a: the inverse transform.
inline Pose2 inverse(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, normalize_angle(-a.theta)};
}

/// ⊖a ⊕ b: the pose of b seen from a.
inline Pose2 between(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  const double dx = b.x - a.x, dy = b.y - a.y;
  return {c * dx + s * dy, -s * dx + c * dy, normalize_angle(b.theta - a.theta)};
}

/// Jacobians of compose(a, b) with respect to a and to b.
inline void compose_jacobians(const Pose2& a, const Pose2& b, Mat3* j_a, Mat3* j_b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  if (j_a) {
    *j_a << 1, 0, -s * b.x - c * b.y,  //
        0, 1, c * b.x - s * b.y,       //
        0, 0, 1;
  }
  if (j_b) {
    *j_b << c, -s, 0,  //
        s, c, 0,       //
        0, 0, 1;
  }
}

/// Jacobian of inverse(a) with respect to a.
inline Mat3 inverse_jacobian(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Mat3 j;
  j << -c, -s, s * a.x - c * a.y,  //
      s, -c, c * a.x + s * a.y,    //
      0, 0, -1;
  return j;
}

/// Jacobians of between(a, b) with respect to a and to b.
inline void between_jacobians(const Pose2& a, const Pose2& b, Mat3* j_a, Mat3* j_b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  const double dx = b.x - a.x, dy = b.y - a.y;
  if (j_a) {
    *j_a << -c, -s, -s * dx + c * dy,  //
        s, -c, -c * dx - s * dy,       //
        0, 0, -1;
  }
  if (j_b) {
    *j_b << c, s, 0,  //
        -s, c, 0,     //
        0, 0, 1;
  }
}

/// The pose change of constant forward speed v (m/s) and turn rate w (rad/s) over dt:
/// an exact circular arc (a straight line when w is ~0).
inline Pose2 arc_motion(double v, double w, double dt) {
  if (std::abs(w) < 1e-9) return {v * dt, 0.0, 0.0};
  const double th = w * dt;
  return {v / w * std::sin(th), v / w * (1.0 - std::cos(th)), th};
}

/// A point given in the frame of `pose`, returned in the frame pose is expressed in.
inline Vec2 transform_point(const Pose2& pose, const Vec2& p_local) {
  return pose.rotation() * p_local + pose.translation();
}

/// Jacobians of transform_point with respect to the pose (2x3) and the local point (2x2).
inline void transform_point_jacobians(const Pose2& pose, const Vec2& p_local, Mat23* j_pose, Mat2* j_point) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  if (j_pose) {
    *j_pose << 1, 0, -s * p_local.x() - c * p_local.y(),  //
        0, 1, c * p_local.x() - s * p_local.y();
  }
  if (j_point) *j_point = pose.rotation();
}

/// A point given in the outer frame, returned in the frame of `pose`.
inline Vec2 inverse_transform_point(const Pose2& pose, const Vec2& p) {
  return pose.rotation().transpose() * (p - pose.translation());
}

/// Jacobians of inverse_transform_point with respect to the pose (2x3) and the point (2x2).
inline void inverse_transform_point_jacobians(const Pose2& pose, const Vec2& p, Mat23* j_pose, Mat2* j_point) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double dx = p.x() - pose.x, dy = p.y() - pose.y;
  if (j_pose) {
    *j_pose << -c, -s, -s * dx + c * dy,  //
        s, -c, -c * dx - s * dy;
  }
  if (j_point) *j_point = pose.rotation().transpose();
}

/// A range-bearing measurement: range in metres, bearing in radians in the sensor frame.
struct RangeBearing {
  double range = 0.0;
  double bearing = 0.0;
  Vec2 vector() const { return {range, bearing}; }
};

/// The range and bearing of a point (global frame) seen from `pose`.
inline RangeBearing observe_point(const Pose2& pose, const Vec2& p) {
  const double dx = p.x() - pose.x, dy = p.y() - pose.y;
  return {std::hypot(dx, dy), normalize_angle(std::atan2(dy, dx) - pose.theta)};
}

/// Jacobians of observe_point with respect to the observer pose (2x3) and the point (2x2).
/// Undefined at range 0; callers gate on a minimum range.
inline void observe_point_jacobians(const Pose2& pose, const Vec2& p, Mat23* h_pose, Mat2* h_point) {
  const double dx = p.x() - pose.x, dy = p.y() - pose.y;
  const double q = dx * dx + dy * dy, r = std::sqrt(q);
  Mat2 hp;
  hp << dx / r, dy / r, -dy / q, dx / q;
  if (h_point) *h_point = hp;
  if (h_pose) {
    h_pose->leftCols<2>() = -hp;
    h_pose->col(2) = Vec2(0.0, -1.0);
  }
}

/// The global point for a range-bearing measurement taken from `pose` (feature initialisation).
inline Vec2 point_from_observation(const Pose2& pose, const RangeBearing& z) {
  const double a = pose.theta + z.bearing;
  return {pose.x + z.range * std::cos(a), pose.y + z.range * std::sin(a)};
}

/// Jacobians of point_from_observation with respect to the pose (2x3) and the measurement (2x2).
inline void point_from_observation_jacobians(const Pose2& pose, const RangeBearing& z, Mat23* g_pose, Mat2* g_z) {
  const double a = pose.theta + z.bearing, c = std::cos(a), s = std::sin(a);
  if (g_pose) {
    *g_pose << 1, 0, -z.range * s,  //
        0, 1, z.range * c;
  }
  if (g_z) {
    *g_z << c, -z.range * s, s, z.range * c;
  }
}

}  // namespace cairn
