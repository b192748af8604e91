// The robot's local mapper (multirobot-exploration seed, "local mapper"): each scan is
// matched against a likelihood field built from the last few keyframe scans, starting
// from odometry; the match and the odometry are fused by their covariances (so a
// direction the scan cannot constrain, like along a corridor, follows odometry). A scan
// becomes a keyframe when the robot has moved far enough; the field is then rebuilt
// around the robot from the keyframe ring (a scrolling window of fixed size). Every
// buffer is sized from the configuration at construction; add_scan() never allocates.
#pragma once

#include <cstdint>
#include <span>

#include "common/fixed_vector.hpp"
#include "common/se2.hpp"
#include "firmware/localmap/likelihood_grid.hpp"
#include "firmware/localmap/scan_matcher.hpp"

namespace cairn::localmap {

struct LocalMapConfig {
  GridConfig grid;
  MatchConfig match;
  int keyframes = 10;                   // scans that make up the local map
  int max_points = 721;                 // per scan
  double keyframe_distance_m = 0.25;    // a new keyframe after this much travel ...
  double keyframe_angle_rad = 0.17;     // ... or this much turning (10°)
  double min_range_m = 0.05, max_range_m = 15.0;  // points used
  double odometry_inflation = 25.0;     // odometry variance × this in the fusion (slip)
  double surface_gap_m = 0.5;           // join neighbouring returns closer than this (0 = points only)
};

const char* validate(const LocalMapConfig& c);

struct LocalMapCounters {
  std::uint64_t scans = 0, matched = 0, rejected = 0, keyframes = 0, rebuilds = 0, points_dropped = 0;
};

struct LocalMapUpdate {
  Pose2 pose;                 // corrected pose in the local frame
  Mat3 covariance = Mat3::Zero();  // of this scan's increment (odometry ⊕ match, fused)
  Pose2 increment;            // corrected motion since the previous scan
  MatchResult match;
  bool matched = false;
  bool keyframe = false;
};

class LocalMapper {
 public:
  explicit LocalMapper(const LocalMapConfig& cfg);

  /// A scan's points in the robot frame (already filtered by range) with the odometry
  /// increment since the previous scan and its covariance.
  LocalMapUpdate add_scan(std::span<const Vec2> points, const Pose2& odom_delta, const Mat3& odom_cov);
  /// Starts over at `pose` with an empty map.
  void reset(const Pose2& pose);

  const Pose2& pose() const { return pose_; }
  const LocalMapCounters& counters() const { return counters_; }
  const LikelihoodGrid& grid() const { return grid_; }
  const LocalMapConfig& config() const { return cfg_; }

 private:
  void add_keyframe(std::span<const Vec2> points);
  void rebuild();

  LocalMapConfig cfg_;
  LikelihoodGrid grid_;
  ScanMatcher matcher_;
  FixedVector<Vec2> ring_;  // keyframes × max_points, points in the local frame
  FixedVector<std::size_t> ring_count_;
  std::size_t ring_next_ = 0, ring_used_ = 0;
  Pose2 pose_, last_keyframe_;
  bool has_map_ = false;
  LocalMapCounters counters_;
};

}  // namespace cairn::localmap
