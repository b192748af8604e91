// cairn-sim's fleet: N SimRobots and the production base pipeline (fusion) in one
// process, on one simulated clock, stepped in lockstep at the physics period. Each robot
// has its own copy of the world, as on the HIL bench today (robots that see and bump into
// each other come with the shared world of the central-mapper work). In each step the
// worker threads take the robots one by one; a robot has its own world and random stream,
// so which worker steps it does not matter. The main thread then takes their messages in
// robot order: the run does not depend on thread timing, the same seed gives the same
// bytes. Messages between robots and base cross a simulated link with latency and loss.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "basestation/fusion.hpp"
#include "basestation/map_frames.hpp"
#include "basestation/mapper/export.hpp"
#include "basestation/mapper/mapper.hpp"
#include "tools/map_quality/map_quality.hpp"
#include "tools/sim/explore_driver.hpp"
#include "tools/sim/sim_robot.hpp"

namespace cairn::sim {

struct FleetSimConfig {
  std::string world_path;
  int robots = 3;
  int threads = 2;  // worker threads stepping the robots (results do not depend on it)
  double duration_s = 300;
  std::uint64_t seed = 7;
  Nanos physics_step = 5 * kNanosPerMilli;
  Nanos link_latency = 5 * kNanosPerMilli;  // robot -> base, each message
  double link_loss = 0.0;                   // fraction of messages lost
  bool shared_world = false;                // robots see and collide with each other
  bool robot_observations = true;           // the base fuses robots' sightings of each other
  Nanos sample_period = 100 * kNanosPerMilli;  // ground truth and estimates written at this rate
  mapper::MapperConfig mapper;                 // the base's central occupancy grid
  bool map_fits_world = true;                  // grid = the world's bounds + 2 m (else mapper's origin/size)
  Nanos map_reframe_period = 10 * kNanosPerSecond;  // re-render moved scans this often, and at the end
  firmware::ExecutiveConfig robot;             // every robot's configuration (id set per robot)
  firmware::FollowerConfig follower;
  /// Exploration instead of the scripted tours (docs/explore.md): frontier bids, the base's
  /// allocator, paths on the global map. The run ends when the allocator reports the world
  /// explored, or at duration_s.
  bool explore = false;
  ExploreConfig exploration;
  /// Coverage of the central map against the world's truth (tools::evaluate) recorded this
  /// often (0: only at the end, in the summary's map figures).
  Nanos coverage_period = 0;
};

/// The speeds cairn-sim's command line and `cairn-eval explore` run the simulated robots at:
/// the safety cap raised to 1 m/s (the built-in robot configuration caps at 0.8 m/s) and
/// the scripted tours at 0.8 m/s. Exploration follows paths at ExploreConfig::follower's speed.
/// The tours look 0.75 s ahead: 0.6 m at cruise, as when the lookahead was fixed (the
/// figures in docs/sim.md and docs/markers.md were measured so).
inline void set_tool_speeds(FleetSimConfig* cfg) {
  cfg->robot.safety.max_v = 1.0;
  cfg->follower.speed = 0.8;
  cfg->follower.lookahead_time_s = 0.75;
}

struct CoverageSample {
  double t_s = 0;
  double coverage = 0, agreement = 0;
  double drivable = 0;  // coverage of the space the robots' bodies can sweep (tools/map_quality/drivable_space.hpp)
};

/// The coverage levels whose first time the summary reports.
inline constexpr double kCoverageLevels[4] = {0.50, 0.90, 0.95, 1.00};

struct ExploreSummary {
  bool explored = false;     // the allocator reported the world explored
  double explored_at_s = 0;  // when (valid if explored)
  explore::AllocatorCounters allocator;
  ExploreCounters driver;
  std::vector<explore::UnreachableArea> unreachable;  // at the end of the run, merged (TaskAllocator::unreachable)
  std::uint64_t unreachable_dropped = 0;              // clusters the robots' latest bids could not carry
};

struct RobotSample {
  Nanos t = 0;
  int robot = 0;
  Pose2 truth, local, global;
  Mat3 global_cov = Mat3::Zero();  // the base's covariance of `global` (at its latest odometry)
  bool has_global = false;
};

struct RobotSummary {
  int id = 0;
  double distance_m = 0;
  double local_rmse_m = 0, global_rmse_m = 0, local_final_err_m = 0, global_final_err_m = 0;
  // Mean normalised estimation error squared of the global estimate against truth: about
  // 3 (pose) and 2 (position) when the base's covariance is consistent, far above when it
  // is overconfident. A filter that trusts a peer's overconfident estimate gets worse.
  double global_nees_pose = 0, global_nees_position = 0;
  std::uint64_t scans = 0, matched = 0, bumps = 0;
};

struct FleetSummary {
  std::vector<RobotSummary> robots;
  std::size_t landmarks = 0, poles = 0;
  double landmark_rmse_m = 0;   // each landmark to its nearest pole
  std::size_t landmarks_far = 0;  // farther than 0.5 m from any pole
  std::uint64_t messages = 0, messages_lost = 0;
  // Robots seen by robots (shared world): sightings, those without a read marker, those fused.
  std::uint64_t robot_sightings = 0, robot_sightings_unidentified = 0, robot_observations_used = 0;
  std::uint64_t robot_sightings_paired = 0;  // unread ones paired with the one robot that explains them
  // The smallest distance between two robots' true centres over the samples (none with
  // one robot). In one shared world bodies touch at twice the body radius.
  std::optional<double> closest_approach_m;
  // Mean NIS of the fused sightings and landmark observations (FusionCounters; none if
  // nothing of the kind was fused): about 2 when the stated covariances are right.
  std::optional<double> sighting_nis_mean, landmark_nis_mean;
  tools::MapQuality map;              // the central grid against the world's ground truth
  std::uint64_t map_scans = 0, map_scans_unplaced = 0;  // LaserScans inserted / not yet placeable
  double sim_seconds = 0, wall_seconds = 0, speed_factor = 0, steps_per_second = 0;
  std::uint64_t steps = 0;
  std::vector<CoverageSample> coverage;  // every coverage_period and at the end (empty if 0)
  /// First recorded time (s) at which coverage reached kCoverageLevels[k]; nullopt if never.
  std::optional<double> time_to_coverage[4];
  std::optional<ExploreSummary> explore;  // set in exploration mode
};

class FleetSim {
 public:
  explicit FleetSim(const FleetSimConfig& cfg);
  ~FleetSim();
  /// Runs to the configured duration; `progress` (may be empty) is called about once per
  /// simulated 10 s with the simulated time.
  void run(const std::function<void(double)>& progress = {});
  const std::vector<RobotSample>& samples() const { return samples_; }
  std::vector<msg::Landmark> landmarks() const;
  /// The base's central map: every robot's LaserScans placed by the fusion's estimates.
  const mapper::Mapper& map() const { return *mapper_; }
  /// Each robot's global trajectory as the base estimated it (for the map picture).
  std::vector<mapper::Trajectory> estimated_trajectories() const;
  /// Figures against the world's ground truth; wall time as measured by the caller.
  FleetSummary summary(double wall_seconds) const;
  const hil::World& world() const { return *worlds_.front(); }
  /// FleetSummary::closest_approach_m, without the rest of the summary.
  std::optional<double> closest_approach_m() const;

 private:
  struct Outbox;
  void deliver(Nanos now);
  void share_world();
  void reframe_map();
  void step_robots();
  void explore_step();
  void record_coverage();
  tools::MapQuality evaluate_map() const;

  FleetSimConfig cfg_;
  std::vector<std::unique_ptr<hil::World>> worlds_;  // one per robot
  std::vector<std::unique_ptr<SimRobot>> robots_;
  std::vector<std::unique_ptr<Outbox>> outboxes_;  // one per robot
  std::unique_ptr<base::Fusion> fusion_;
  std::unique_ptr<mapper::Mapper> mapper_;
  base::MapFrames map_frames_;
  std::uint64_t map_scans_unplaced_ = 0;
  Nanos next_reframe_ = 0;
  std::vector<RobotSample> samples_;
  std::atomic<std::size_t> next_robot_{0};  // the next robot a worker takes in this step
  std::uint64_t steps_ = 0;
  Nanos now_ = 0;
  std::unique_ptr<ExploreDriver> explore_;
  std::vector<ExploreDriver::RobotView> views_;
  std::vector<ExploreDriver::PathOrder> orders_;
  std::vector<Pose2> corrections_;  // local_to_global per robot at the last explore step
  bool explored_ = false;
  Nanos next_coverage_ = 0;
  std::vector<CoverageSample> coverage_;
  mutable std::unique_ptr<tools::Reference> reference_;  // the truth the map is scored against: a cache, built once
};

}  // namespace cairn::sim
