// Cooperative concurrent mapping and localization (Fenwick, Newman, Leonard):
// one EKF whose state holds every robot (x, y, θ) and every point feature (x, y)
// with the full joint covariance (paper eq. 2, 3). Prediction and update are
// single-vehicle stochastic mapping applied to the joint state; robots observe
// features and each other.
//
// Cost: the measurement Jacobian touches only the observer's and the target's
// blocks and is never formed densely. A prediction is O(n); an update of m
// observations is O(n²·m): one symmetric rank-2m downdate P − W Wᵀ with W = P Hᵀ L⁻ᵀ
// (S = L Lᵀ), on one triangle; the expanded Joseph form (two full n×n×2m products, about
// four times the flops) is kept as an option. Adding a feature is O(n). No O(n³) step.
// Memory is the n×n covariance, grown geometrically.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <iosfwd>
#include <span>
#include <unordered_map>
#include <vector>

#include "common/se2.hpp"

namespace cairn::ccml {

using RobotId = std::uint32_t;
using FeatureId = std::uint32_t;

/// One range-bearing observation taken by `observer` of a feature or of another robot's marker.
struct Measurement {
  enum class Target : std::uint8_t { kFeature, kRobot };
  RobotId observer = 0;
  Target target_kind = Target::kFeature;
  std::uint32_t target = 0;  // FeatureId or RobotId
  RangeBearing z;
  Mat2 R = Mat2::Identity();
};

struct Innovation {
  Vec2 nu = Vec2::Zero();   // z - h(x), bearing wrapped
  Mat2 S = Mat2::Identity();
  double nis() const { return nu.dot(S.ldlt().solve(nu)); }
};

/// How update() forms the posterior covariance. Both are exact in exact arithmetic.
enum class CovarianceUpdate : std::uint8_t {
  kSymmetric,  // P − W Wᵀ, W = P Hᵀ L⁻ᵀ: one rank-2m update of the lower triangle, mirrored
  kJoseph,     // (I−KH) P (I−KH)ᵀ + K R Kᵀ, expanded to use only P Hᵀ: two full n×n×2m products
};

struct UpdateResult {
  bool applied = false;
  bool refused = false;  // not applied because the innovation, gain or result was not finite (state unchanged)
  double nis = 0.0;    // joint normalised innovation squared
  int dof = 0;         // 2 per measurement
};

class CcmlFilter {
 public:
  explicit CcmlFilter(std::size_t initial_capacity = 32);

  // ---- robots
  /// Adds a robot with its initial pose and covariance, uncorrelated with everything else.
  void add_robot(RobotId id, const Pose2& pose, const Mat3& cov);
  bool has_robot(RobotId id) const { return robots_.count(id) != 0; }
  /// Removes a robot (marginalises it out). The map keeps what it learnt from it.
  void remove_robot(RobotId id);
  Pose2 robot_pose(RobotId id) const;
  Mat3 robot_cov(RobotId id) const;
  /// Overwrites a robot's mean (used to re-linearise a joining robot); covariance unchanged.
  void set_robot_pose(RobotId id, const Pose2& pose);
  std::vector<RobotId> robot_ids() const;

  // ---- features
  /// Initialises a new feature from an observation; returns its id.
  FeatureId add_feature(RobotId observer, const RangeBearing& z, const Mat2& R);
  /// Adds a feature at a known position/covariance, uncorrelated (for tests, priors).
  FeatureId add_feature_prior(const Vec2& position, const Mat2& cov);
  bool has_feature(FeatureId id) const { return features_.count(id) != 0; }
  /// Removes a feature (marginalises it out); O(n²).
  void remove_feature(FeatureId id);
  Vec2 feature(FeatureId id) const;
  Mat2 feature_cov(FeatureId id) const;
  std::vector<FeatureId> feature_ids() const;
  std::size_t feature_count() const { return features_.size(); }

  // ---- estimation
  /// x_r ← x_r ⊕ δ with δ's covariance Q (robot frame); O(n). False (state unchanged) when
  /// the result would not be finite.
  bool predict(RobotId id, const Pose2& delta, const Mat3& delta_cov);
  /// Adds process noise (global frame) to a robot's covariance; false (unchanged) if not finite.
  bool add_process_noise(RobotId id, const Mat3& q_global);
  /// Innovation and its covariance for one measurement (individual compatibility).
  Innovation innovation(const Measurement& m) const;
  /// Joint innovation and covariance S = H P Hᵀ + R for a set of measurements (joint compatibility).
  void joint_innovation(std::span<const Measurement> ms, Eigen::VectorXd* nu, Eigen::MatrixXd* S) const;
  /// Which covariance form update() uses (default kSymmetric). Not part of save()/load().
  void set_covariance_update(CovarianceUpdate form) { covariance_update_ = form; }
  CovarianceUpdate covariance_update() const { return covariance_update_; }
  /// EKF update with all measurements at once. With iterations > 1 it is an
  /// iterated EKF (Gauss-Newton on the MAP), re-linearising at each iterate; the first
  /// linearisation point is the prior mean, except that `seed` (robot, pose) replaces one
  /// robot's pose there (a joining robot localised by JCBB's alignment).
  struct Seed {
    RobotId robot;
    Pose2 pose;
  };
  UpdateResult update(std::span<const Measurement> ms, int iterations = 1, const Seed* seed = nullptr);

  // ---- access
  std::size_t dimension() const { return n_; }
  Eigen::Ref<const Eigen::VectorXd> mean() const { return x_.head(n_); }
  Eigen::Ref<const Eigen::MatrixXd> covariance() const { return P_.topLeftCorner(n_, n_); }
  /// Offset of a robot / feature in the state vector (for tests and analysis).
  int robot_offset(RobotId id) const;
  int feature_offset(FeatureId id) const;
  /// Binary snapshot of the whole estimator (state, covariance, ids); load() restores it exactly.
  void save(std::ostream& out) const;
  static CcmlFilter load(std::istream& in);

  /// Smallest eigenvalue of the symmetric part of P and the largest asymmetry (health checks).
  double min_eigenvalue() const;
  double max_asymmetry() const;

 private:
  struct Slot {
    int offset;
    int dim;
  };
  struct Block {  // the two non-zero blocks of one measurement's Jacobian
    int obs_offset;
    Mat23 h_obs;
    int tgt_offset;
    Mat2 h_tgt;
  };

  int append(int dim);
  void erase(int offset, int dim);
  void reserve(std::size_t dim);
  Pose2 pose_at(int offset, const Eigen::VectorXd& x) const { return {x(offset), x(offset + 1), x(offset + 2)}; }
  Vec2 predicted_measurement(const Measurement& m, const Eigen::VectorXd& x, Block* block) const;
  int target_offset(const Measurement& m) const;

  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  std::size_t n_ = 0;
  std::unordered_map<RobotId, Slot> robots_;
  std::unordered_map<FeatureId, Slot> features_;
  FeatureId next_feature_ = 1;
  CovarianceUpdate covariance_update_ = CovarianceUpdate::kSymmetric;
};

}  // namespace cairn::ccml
