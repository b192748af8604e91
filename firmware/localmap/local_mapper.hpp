// The robot's local mapper (multirobot-exploration seed, "local mapper"): each scan is
// matched against a likelihood field built from the last few keyframe scans, starting
// from odometry; the match and the odometry are fused by their covariances (so a
// direction the scan cannot constrain, like along a corridor, follows odometry). A scan
// becomes a keyframe when the robot has moved far enough; the field is then rebuilt
// around the robot from the keyframe ring (a scrolling window of fixed size). Every
// buffer is sized from the configuration at construction; add_scan() never allocates.
//
// The rebuild can leave the RT thread (async_rebuild): a keyframe then only copies the
// keyframe ring into a request buffer, a lower-priority worker builds the next field into
// a second grid while matching goes on against the current one, and the RT thread swaps
// the two when the worker is done. Threads and calls:
//   RT thread (one):     add_scan(), reset(), swap_if_ready() (add_scan calls it first)
//   worker thread (one): build_pending(); poll rebuild_requested() to know when to call it
//   any thread:          rebuild_state()
// The handoff is one atomic state, idle -> requested (RT) -> building -> ready (worker)
// -> idle (RT swap), with acquire/release: no lock, no allocation, no waiting on either
// side. A keyframe that comes while the worker builds is requested again after the swap
// (the newest ring always gets built); reset() discards a build under way. Join the worker
// before destroying the mapper.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
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
  // The drift each increment reports (LocalMapUpdate::covariance). false: each scan's fused
  // covariance, summed by the base scan after scan (far too loose in heading). true: what the
  // pose's error relative to the map grows by (docs/localmap.md); it makes a fleet fusing
  // sightings 2.4× better, but with landmarks the base's map then turns (office: landmarks
  // 1.0 → 12 cm), so it is not the default until that bias is found.
  bool map_relative_drift = false;
  // false: add_scan() rebuilds the field itself on a keyframe (tests, tools). true: it
  // only requests the rebuild, which build_pending() does on a worker thread (see below).
  bool async_rebuild = false;
};

const char* validate(const LocalMapConfig& c);

struct LocalMapCounters {
  std::uint64_t scans = 0, matched = 0, rejected = 0, keyframes = 0, rebuilds = 0, points_dropped = 0;
  std::uint64_t rebuilds_deferred = 0;  // async: keyframes that came while the worker was building
};

enum class RebuildState : std::uint8_t { kIdle, kRequested, kBuilding, kReady };

struct LocalMapUpdate {
  Pose2 pose;                 // corrected pose in the local frame
  // What this scan adds to the pose's drift (robot frame at the previous pose). With
  // map_relative_drift: how far the pose's error relative to the map it was matched
  // against has grown beyond what the scans since the last keyframe reported
  // (local_mapper.cpp says why); without: the scan's fused covariance (odometry's if not matched).
  Mat3 covariance = Mat3::Zero();
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

  /// Worker thread (async_rebuild): builds the requested field into the spare grid.
  /// Returns false at once when no rebuild is requested.
  bool build_pending();
  /// RT thread: puts a field the worker has built in use; true if it did.
  bool swap_if_ready();
  RebuildState rebuild_state() const { return state_.load(std::memory_order_acquire); }
  bool rebuild_requested() const { return rebuild_state() == RebuildState::kRequested; }

  const Pose2& pose() const { return pose_; }
  const LocalMapCounters& counters() const { return counters_; }
  const LikelihoodGrid& grid() const { return *current_; }  // the field matching uses (RT thread)
  const LocalMapConfig& config() const { return cfg_; }

 private:
  void add_keyframe(std::span<const Vec2> points);
  void request_rebuild();

  LocalMapConfig cfg_;
  std::unique_ptr<LikelihoodGrid> current_, spare_;  // spare_: async only, the worker's
  ScanMatcher matcher_;
  FixedVector<Vec2> ring_;  // keyframes × max_points, points in the local frame
  FixedVector<std::size_t> ring_count_;
  std::size_t ring_next_ = 0, ring_used_ = 0;
  Pose2 pose_, last_keyframe_;
  Mat3 map_relative_cov_ = Mat3::Zero();       // the pose's error relative to the map, local axes
  Mat3 map_relative_reported_ = Mat3::Zero();  // how much of it this keyframe interval reported
  bool has_map_ = false;
  LocalMapCounters counters_;
  // Async rebuild. The request (the ring's copy and the window's centre) and spare_ belong
  // to the worker from requested to ready, to the RT thread otherwise.
  std::unique_ptr<Vec2[]> request_points_;
  std::unique_ptr<std::size_t[]> request_count_;
  std::size_t request_used_ = 0;
  Vec2 request_centre_ = Vec2::Zero();
  std::atomic<RebuildState> state_{RebuildState::kIdle};
  bool rebuild_again_ = false;  // RT: a keyframe came while the worker was building
  bool discard_ready_ = false;  // RT: reset() while the worker was building
};

}  // namespace cairn::localmap
