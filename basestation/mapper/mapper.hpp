// The central mapper (docs/mapper.md; issue 14; the multirobot-exploration seed's
// "central mapper"): one log-odds occupancy grid built from every robot's corrected
// LaserScans, each placed at the global pose the base's estimator gives for the scan's
// time. Scans are kept in a bounded store so that a correction of a robot's trajectory
// re-renders the scans it moved. Thresholds p_o / p_c classify cells as obstacle / clear /
// unknown (the seed's bid-building classes).
//
// Pure algorithm on Cairn's own types (common/messages.hpp): no DDS, no clock, no I/O;
// deterministic for a given call sequence. Not thread-safe: one owner thread.
//
// Inverse sensor model, per beam of a scan at sensor pose s (global):
//   - a return at range r (min_range_m <= r < max_range_m): the cells the beam crosses
//     from s up to the endpoint's cell get log-odds l_miss, the endpoint's cell l_hit;
//   - no return (range 0) or r >= max_range_m: a max-range beam, cells up to
//     max_range_m get l_miss, no cell gets l_hit (a beam that saw nothing clears only);
//   - r < min_range_m: skipped (counted);
//   - within one scan every cell is updated at most once, a hit winning over a miss
//     (many beams cross the cells next to the sensor; counting each would clear them as
//     if seen by many scans).
// Log-odds are accumulated exactly (integers, milli-log-odds) and clamped only when read,
// so that removing a scan's contribution (re-rendering) is exact.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "basestation/mapper/grid.hpp"
#include "common/clock.hpp"
#include "common/messages.hpp"
#include "common/se2.hpp"

namespace cairn {
class ConfigSection;
}

namespace cairn::mapper {

struct MapperConfig {
  // Grid: bounded, fixed at construction. The map covers
  // [origin_x, origin_x + width_m) × [origin_y, origin_y + height_m).
  double resolution_m = 0.15;  // the seed's 15 cm
  double origin_x = -50.0, origin_y = -50.0;
  double width_m = 100.0, height_m = 100.0;
  std::size_t max_cells = 16u << 20;  // refuses a configuration whose grid would be larger

  // Beams.
  double min_range_m = 0.05;
  double max_range_m = 15.0;  // as the robot's local map (mapping.max_range_m)

  // Inverse sensor model (probabilities; log-odds inside). p_hit/p_miss as in
  // Thrun, Burgard & Fox, "Probabilistic Robotics", ch. 9 (0.7 / 0.4).
  double p_hit = 0.7, p_miss = 0.4;
  double p_min = 0.12, p_max = 0.97;  // clamp when read

  // Classification (the seed's p_o / p_c; defaults are ROS map_server's thresholds).
  double p_o = 0.65;   // obstacle: p >= p_o
  double p_c = 0.196;  // clear: p <= p_c; unknown otherwise or never seen

  // Every Nth LaserScan per robot is inserted (the robots already publish every 10th
  // scan, the seed's rate: mapping.scan_publish_every, so 1 by default).
  int insert_every = 1;

  // Scan store for re-rendering: bounded memory; when full the oldest scan is dropped
  // from the store (its contribution stays in the grid, frozen at its last pose).
  std::size_t store_bytes = 64u << 20;

  // A stored scan is re-rendered when a correction moves its beam endpoints by more than
  // this: |Δt| + |Δθ|·max_range_m > rerender_shift_m. Half a cell by default.
  double rerender_shift_m = 0.075;

  // A return within this distance of another robot's estimated centre (at insertion) is
  // that robot's body, not the building: its beam clears the cells before it and marks no
  // obstacle. The body (0.3 m) plus what the estimates and 0.1 s of motion may be off.
  // 0: robots are drawn as obstacles.
  double robot_mask_radius_m = 0.45;
};

/// Reads [mapper] (every key optional, defaults above; docs/config.md). Throws ConfigError.
MapperConfig mapper_config_from(const ConfigSection& section);
/// Throws std::invalid_argument naming the bad parameter.
void validate(const MapperConfig& config);

struct MapperCounters {
  std::uint64_t scans_received = 0;
  std::uint64_t scans_inserted = 0;
  std::uint64_t scans_subsampled = 0;    // skipped by insert_every
  std::uint64_t scans_invalid = 0;       // non-finite pose or angles, n_beams > kMaxBeams
  std::uint64_t scans_outside = 0;       // sensor outside the grid: not inserted
  std::uint64_t beams_clipped = 0;       // beams leaving the grid (inserted up to the border)
  std::uint64_t beams_short = 0;         // r < min_range_m
  std::uint64_t beams_max_range = 0;     // no return or r >= max_range_m: cleared only
  std::uint64_t beams_on_robots = 0;     // ending on another robot's body: cleared only
  std::uint64_t store_dropped = 0;       // oldest scans dropped from a full store (frozen in the grid)
  std::uint64_t scans_not_stored = 0;    // a single scan larger than the whole store
  std::uint64_t rerendered = 0;          // scans moved by a correction
  std::uint64_t rerender_invalid_pose = 0;  // a correction gave a non-finite pose: scan left where it was
  std::uint64_t rerender_outside = 0;    // a correction moved the sensor outside the grid: scan removed
};

/// What the re-render callback sees of one stored scan.
struct ScanInfo {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos stamp = 0;
  Pose2 local_pose;     // the scan's sensor pose in the robot's local frame (LaserScan::pose)
  Pose2 sensor_offset;  // laser in the robot frame (LaserScan::sensor_offset)
  Pose2 pose;           // the global sensor pose it is rendered at now
};

/// A robot's body pose (global) at a time of its clock.
struct TimedPose {
  Nanos stamp = 0;
  Pose2 pose;
};

struct RerenderStats {
  std::size_t examined = 0, moved = 0, removed = 0;
};

class Mapper {
 public:
  enum class AddResult { kInserted, kSubsampled, kRejected };

  /// Throws std::invalid_argument for an invalid configuration (validate()).
  explicit Mapper(const MapperConfig& config);

  /// One LaserScan with the global pose of its *sensor* at scan.stamp. Subsampled per
  /// robot (insert_every); rejected (counted) for a non-finite pose or a sensor outside
  /// the grid. Never throws on data.
  /// `robots`: the global centres of the other robots now; returns on their bodies
  /// (robot_mask_radius_m) clear the cells before them and mark no obstacle.
  AddResult add_scan(const msg::LaserScan& scan, const Pose2& sensor_pose, std::span<const Vec2> robots = {});
  /// The same with the robot's local-to-global transform (PoseCorrection::local_to_global):
  /// sensor pose = local_to_global ⊕ scan.pose.
  AddResult add_scan_local(const msg::LaserScan& scan, const Pose2& local_to_global, std::span<const Vec2> robots = {});

  /// Re-renders robot `robot`'s stored scans: `sensor_pose_at` gives each one's new
  /// global sensor pose (nullopt: leave it). Scans that moved by more than
  /// rerender_shift_m are removed from the grid at the old pose and inserted at the new.
  using SensorPoseFn = std::function<std::optional<Pose2>(const ScanInfo&)>;
  RerenderStats rerender(std::uint16_t robot, const SensorPoseFn& sensor_pose_at);
  /// The estimator moved the robot's trajectory: `robot_pose_at(t)` is the robot's global
  /// pose at time t (nullopt: unknown); the sensor pose adds the scan's sensor_offset.
  RerenderStats on_trajectory_corrected(std::uint16_t robot, const std::function<std::optional<Pose2>(Nanos)>& robot_pose_at);
  /// The estimator moved the robot's local frame (global = local_to_global ⊕ local).
  RerenderStats on_frame_corrected(std::uint16_t robot, const Pose2& local_to_global);

  const GridGeometry& geometry() const { return geometry_; }
  const MapperConfig& config() const { return config_; }
  /// Clamped log-odds, occupancy probability and class of a cell (i, j must be inside).
  double log_odds(int i, int j) const;
  double probability(int i, int j) const;
  Cell classify(int i, int j) const;
  bool observed(int i, int j) const { return observed_[geometry_.index(i, j)] > 0; }
  ClassGrid classified() const;

  /// Cells whose class may have changed since the last call, as an inclusive bounding
  /// box [i0, i1] × [j0, j1]; nullopt when none (for the MapTile publisher).
  struct Region {
    int i0, j0, i1, j1;
  };
  std::optional<Region> take_changed();

  /// The global sensor positions of a robot's stored scans, oldest first (for figures).
  std::vector<Vec2> trajectory(std::uint16_t robot) const;
  /// The robot's body poses at its stored scans (the sensor pose as rendered now ⊕ the
  /// inverse of the laser's mount), in time order: the trajectory the map was built from.
  std::vector<TimedPose> body_trajectory(std::uint16_t robot) const;
  std::vector<std::uint16_t> robots() const;

  const MapperCounters& counters() const { return counters_; }
  std::size_t stored_scans() const { return store_.size(); }
  std::size_t stored_bytes() const { return store_bytes_; }

 private:
  struct Stored {
    ScanInfo info;
    float angle_min = 0, angle_increment = 0;
    std::vector<std::uint16_t> ranges_mm;
    std::vector<bool> on_robot;  // per beam, a return on another robot; empty when none is
    bool removed = false;  // moved outside the grid by a correction; erased after the pass
  };
  static std::size_t bytes_of(const Stored& s) {
    return sizeof(Stored) + s.ranges_mm.capacity() * sizeof(std::uint16_t) + s.on_robot.capacity() / 8;
  }

  /// Adds (sign +1) or removes (-1) one scan's contribution at `pose`.
  void render(const Stored& s, const Pose2& pose, int sign);
  /// Sets s->on_robot for the returns within robot_mask_radius_m of a robot centre.
  void mark_robot_returns(Stored* s, const Pose2& sensor_pose, std::span<const Vec2> robots);
  void touch(int i, int j);
  bool moved_enough(const Pose2& a, const Pose2& b) const;

  MapperConfig config_;
  GridGeometry geometry_;
  std::int32_t l_hit_ = 0, l_miss_ = 0, l_min_ = 0, l_max_ = 0;  // milli-log-odds
  std::vector<std::int32_t> sum_;        // unclamped milli-log-odds per cell
  std::vector<std::uint32_t> observed_;  // number of stored/frozen scans that touched the cell
  std::vector<std::uint32_t> mark_;      // per-scan "already updated" stamps
  std::uint32_t mark_stamp_ = 0;
  std::vector<std::size_t> scratch_hits_, scratch_misses_;
  std::optional<Region> changed_;
  std::deque<Stored> store_;
  std::size_t store_bytes_ = 0;
  std::map<std::uint16_t, std::uint64_t> seen_;  // per robot, for insert_every
  MapperCounters counters_;
};

/// log(p / (1 - p)).
double logit(double p);

}  // namespace cairn::mapper
