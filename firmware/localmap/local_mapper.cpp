#include "firmware/localmap/local_mapper.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cairn::localmap {

const char* validate(const LocalMapConfig& c) {
  if (const char* e = validate(c.grid)) return e;
  if (const char* e = validate(c.match)) return e;
  if (c.keyframes < 1 || c.keyframes > 100) return "keyframes must be in [1, 100]";
  if (c.max_points < 3 || c.max_points > 8192) return "max_points must be in [3, 8192]";
  if (!(c.keyframe_distance_m > 0) || !(c.keyframe_angle_rad > 0)) return "keyframe thresholds must be > 0";
  if (!(c.min_range_m >= 0 && c.max_range_m > c.min_range_m)) return "need 0 <= min_range_m < max_range_m";
  if (!(c.odometry_inflation >= 1 && c.odometry_inflation <= 1e6)) return "odometry_inflation must be in [1, 1e6]";
  return nullptr;
}

namespace {
LocalMapConfig checked(const LocalMapConfig& c) {
  if (const char* e = validate(c)) throw std::invalid_argument(std::string("local map: ") + e);
  return c;
}

// The field around `centre` from `used` keyframes stored `stride` points apart: the one
// build both the inline and the worker's rebuild run, so they give the same field.
void build_field(LikelihoodGrid* grid, const Vec2& centre, const Vec2* points, const std::size_t* counts,
                 std::size_t used, std::size_t stride, double surface_gap) {
  grid->reset(centre);
  for (std::size_t k = 0; k < used; ++k) grid->add_surface(std::span<const Vec2>(points + k * stride, counts[k]), surface_gap);
  grid->finish();
}
}  // namespace

LocalMapper::LocalMapper(const LocalMapConfig& cfg)
    : cfg_(checked(cfg)),
      current_(std::make_unique<LikelihoodGrid>(cfg.grid)),
      matcher_(cfg.match, static_cast<std::size_t>(cfg.max_points)),
      ring_(static_cast<std::size_t>(cfg.keyframes) * static_cast<std::size_t>(cfg.max_points)),
      ring_count_(static_cast<std::size_t>(cfg.keyframes)) {
  for (int i = 0; i < cfg.keyframes; ++i) (void)ring_count_.push_back(0);
  for (std::size_t i = 0; i < ring_.capacity(); ++i) (void)ring_.push_back(Vec2::Zero());
  if (cfg.async_rebuild) {
    spare_ = std::make_unique<LikelihoodGrid>(cfg.grid);
    request_points_ = std::make_unique<Vec2[]>(ring_.capacity());
    request_count_ = std::make_unique<std::size_t[]>(static_cast<std::size_t>(cfg.keyframes));
  }
}

void LocalMapper::reset(const Pose2& pose) {
  pose_ = pose;
  last_keyframe_ = pose;
  has_map_ = false;
  map_relative_cov_.setZero();
  map_relative_reported_.setZero();
  ring_next_ = ring_used_ = 0;
  current_->reset(pose.translation());
  // A request not claimed yet is dropped, a finished one too; one being built is dropped when ready.
  RebuildState s = RebuildState::kRequested;
  if (!state_.compare_exchange_strong(s, RebuildState::kIdle, std::memory_order_acquire)) {
    if (s == RebuildState::kReady) state_.store(RebuildState::kIdle, std::memory_order_release);
    discard_ready_ = s == RebuildState::kBuilding;
  }
  rebuild_again_ = false;
}

void LocalMapper::add_keyframe(std::span<const Vec2> points) {
  const std::size_t base = ring_next_ * static_cast<std::size_t>(cfg_.max_points);
  std::size_t n = 0;
  for (const Vec2& p : points) {
    if (n == static_cast<std::size_t>(cfg_.max_points)) {
      ++counters_.points_dropped;
      continue;
    }
    ring_[base + n++] = transform_point(pose_, p);
  }
  ring_count_[ring_next_] = n;
  ring_next_ = (ring_next_ + 1) % static_cast<std::size_t>(cfg_.keyframes);
  if (ring_used_ < static_cast<std::size_t>(cfg_.keyframes)) ++ring_used_;
  last_keyframe_ = pose_;
  ++counters_.keyframes;
  if (cfg_.async_rebuild) {
    request_rebuild();
    return;
  }
  build_field(current_.get(), last_keyframe_.translation(), &ring_[0], &ring_count_[0], ring_used_,
              static_cast<std::size_t>(cfg_.max_points), cfg_.surface_gap_m);
  ++counters_.rebuilds;
  has_map_ = true;
}

void LocalMapper::request_rebuild() {
  RebuildState s = state_.load(std::memory_order_acquire);
  // A request the worker has not claimed yet is replaced by this newer one.
  if (s == RebuildState::kRequested &&
      state_.compare_exchange_strong(s, RebuildState::kIdle, std::memory_order_acquire)) {
    s = RebuildState::kIdle;
  }
  if (s != RebuildState::kIdle) {  // building or ready: ask again after the swap
    rebuild_again_ = true;
    ++counters_.rebuilds_deferred;
    return;
  }
  const auto stride = static_cast<std::size_t>(cfg_.max_points);
  for (std::size_t k = 0; k < ring_used_; ++k) {
    std::copy_n(&ring_[k * stride], ring_count_[k], request_points_.get() + k * stride);
    request_count_[k] = ring_count_[k];
  }
  request_used_ = ring_used_;
  request_centre_ = last_keyframe_.translation();
  state_.store(RebuildState::kRequested, std::memory_order_release);
}

bool LocalMapper::build_pending() {
  RebuildState s = RebuildState::kRequested;
  if (!state_.compare_exchange_strong(s, RebuildState::kBuilding, std::memory_order_acquire,
                                      std::memory_order_relaxed)) {
    return false;
  }
  build_field(spare_.get(), request_centre_, request_points_.get(), request_count_.get(), request_used_,
              static_cast<std::size_t>(cfg_.max_points), cfg_.surface_gap_m);
  state_.store(RebuildState::kReady, std::memory_order_release);
  return true;
}

bool LocalMapper::swap_if_ready() {
  if (state_.load(std::memory_order_acquire) != RebuildState::kReady) return false;
  const bool use = !discard_ready_;
  if (use) {
    std::swap(current_, spare_);
    has_map_ = true;
    ++counters_.rebuilds;
  }
  discard_ready_ = false;
  state_.store(RebuildState::kIdle, std::memory_order_release);
  if (rebuild_again_) {  // idle now, so this request goes out
    rebuild_again_ = false;
    request_rebuild();
  }
  return use;
}

LocalMapUpdate LocalMapper::add_scan(std::span<const Vec2> points, const Pose2& odom_delta, const Mat3& odom_cov) {
  ++counters_.scans;
  swap_if_ready();
  LocalMapUpdate u;
  const Pose2 previous = pose_;
  const Pose2 guess = compose(pose_, odom_delta);
  pose_ = guess;
  // The increment's covariance in the local frame's axes at the previous pose.
  const Mat2 r = previous.rotation();
  Mat3 rot = Mat3::Identity();
  rot.topLeftCorner<2, 2>() = r;
  // Wheel slip is not in the odometry's noise model: in the fusion it is trusted
  // `odometry_inflation` times less (variance), so the scan wins wherever it pins the pose.
  const Mat3 odom_local = cfg_.odometry_inflation * (rot * odom_cov * rot.transpose());
  Mat3 fused_local = odom_local;  // the scan's fused covariance (odometry's until matched)
  bool relative = false;  // the error relative to the map was carried (else: odometry alone)
  if (has_map_) {
    u.match = matcher_.match(*current_, points, guess);
    if (u.match.ok) {
      // Fuse: guess (odometry) and match as two measurements of the same pose.
      const Mat3 s = odom_local + u.match.covariance;
      const Mat3 k = odom_local * s.inverse();
      Vec3 innovation = u.match.pose.vector() - guess.vector();
      innovation.z() = normalize_angle(innovation.z());
      Vec3 fused = guess.vector() + k * innovation;
      fused.z() = normalize_angle(fused.z());
      pose_ = Pose2::from_vector(fused);
      // The pose's error relative to the map (the current keyframes), carried by the same
      // gain: where the scan pins the pose it stays bounded, where it does not (along a
      // corridor) it grows with the odometry (inflated for slip, as in the gain: with the
      // bare model a robot's drift along its path came out several times too small).
      const Mat3 i_k = Mat3::Identity() - k;
      if (cfg_.map_relative_drift)
        map_relative_cov_ = i_k * (map_relative_cov_ + odom_local) * i_k.transpose() + k * u.match.covariance * k.transpose();
      fused_local = i_k * odom_local;
      u.matched = true;
      ++counters_.matched;
      relative = true;
    } else {
      ++counters_.rejected;
    }
  }
  u.pose = pose_;
  u.increment = between(previous, pose_);
  const Pose2 since = between(last_keyframe_, pose_);
  if (ring_used_ == 0 || std::hypot(since.x, since.y) >= cfg_.keyframe_distance_m ||
      std::abs(since.theta) >= cfg_.keyframe_angle_rad) {
    add_keyframe(points);
    u.keyframe = true;
  }
  if (!cfg_.map_relative_drift) {
    // The default: the scan's fused covariance (the bare odometry's when not matched), which
    // the base sums scan by scan; far too loose in heading (docs/markers.md).
    if (relative) {
      u.covariance = rot.transpose() * fused_local * rot;
      u.covariance = 0.5 * (u.covariance + u.covariance.transpose());
    } else {
      u.covariance = odom_cov;
    }
    return u;
  }
  if (!relative) map_relative_cov_ += odom_local;  // not matched (or no map yet): odometry alone
  // map_relative_drift: scans matched against one map share that map's error, so their
  // errors relative to it do not add up scan by scan; what the pose has drifted is that
  // error as it stands when the scan becomes a keyframe, and so part of the map. Each scan
  // reports how far the error relative to the map has grown beyond what this keyframe
  // interval already reported (the positive part), so the base's covariance covers it
  // between keyframes too, and a lost increment loses only its own share.
  Mat3 grown = map_relative_cov_ - map_relative_reported_;
  grown = 0.5 * (grown + grown.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(grown);
  const Mat3 positive =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  map_relative_reported_ += positive;
  u.covariance = rot.transpose() * positive * rot;
  u.covariance = 0.5 * (u.covariance + u.covariance.transpose());
  if (u.keyframe) {
    map_relative_cov_.setZero();
    map_relative_reported_.setZero();
  }
  return u;
}

}  // namespace cairn::localmap
