#include "firmware/executive/odometry.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

Pose2 arc_from_wheels(double dl, double dr, double track, Eigen::Matrix<double, 3, 2>* j) {
  const double ds = 0.5 * (dl + dr), dth = (dr - dl) / track, h = 0.5 * dth;
  const double c = std::cos(h), s = std::sin(h);
  if (j) {
    *j << 0.5 * c + ds * s / (2 * track), 0.5 * c - ds * s / (2 * track),  //
        0.5 * s - ds * c / (2 * track), 0.5 * s + ds * c / (2 * track),    //
        -1.0 / track, 1.0 / track;
  }
  return {ds * c, ds * s, dth};  // the chord of the arc at the mean heading
}

OdometryStep DiffOdometry::update(std::int32_t left_counts, std::int32_t right_counts) {
  OdometryStep out;
  if (!primed_) {
    primed_ = true;
    left_ = left_counts;
    right_ = right_counts;
    return out;
  }
  const canopen::WheelOdometry w = canopen::wheel_odometry(g_, left_counts, right_counts, left_, right_, 0, 0);
  left_ = left_counts;
  right_ = right_counts;
  Eigen::Matrix<double, 3, 2> j;
  out.delta = arc_from_wheels(w.left_m, w.right_m, g_.track_m, &j);
  const double vl = n_.k_per_sqrt_m * n_.k_per_sqrt_m * std::abs(w.left_m) + n_.floor_m * n_.floor_m;
  const double vr = n_.k_per_sqrt_m * n_.k_per_sqrt_m * std::abs(w.right_m) + n_.floor_m * n_.floor_m;
  out.covariance = j * Eigen::Vector2d(vl, vr).asDiagonal() * j.transpose();
  out.distance = std::abs(0.5 * (w.left_m + w.right_m));
  return out;
}

void accumulate(OdometryStep* acc, const OdometryStep& step) {
  Mat3 ja, jb;
  compose_jacobians(acc->delta, step.delta, &ja, &jb);
  acc->covariance = ja * acc->covariance * ja.transpose() + jb * step.covariance * jb.transpose();
  acc->delta = compose(acc->delta, step.delta);
  acc->distance += step.distance;
}

void split_step(const OdometryStep& step, double f, OdometryStep* head, OdometryStep* tail) {
  f = std::clamp(f, 0.0, 1.0);
  // The step is the chord (ds·cos h, ds·sin h, 2h) of an arc; recover the signed ds.
  const double h = 0.5 * step.delta.theta;
  const double along = step.delta.x * std::cos(h) + step.delta.y * std::sin(h);
  const double ds = std::copysign(std::hypot(step.delta.x, step.delta.y), along);
  const double hf = f * h;
  head->delta = {f * ds * std::cos(hf), f * ds * std::sin(hf), f * step.delta.theta};
  head->covariance = f * step.covariance;
  head->distance = f * step.distance;
  tail->delta = between(head->delta, step.delta);
  tail->covariance = (1.0 - f) * step.covariance;
  tail->distance = step.distance - head->distance;
}

}  // namespace cairn::firmware
