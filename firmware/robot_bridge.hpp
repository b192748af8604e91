// The robot's DDS edge (a non-RT worker): converts Cairn's messages (common/dds/convert.hpp)
// and drains the executive's queues onto the
// OdometryIncrement, LaserScan and FeatureObservations topics, publishes RobotStatus
// (loop statistics, stop reason, devices), and takes this robot's PoseCorrection and
// TaskAssignment, which keep the base-station link alive, and this robot's SafetyReset
// (an operator's e-stop reset, handed to Executive::request_reset()), and the base's global
// map (MapTile, into a GlobalMap of configured size). With no executive (a robot
// configured without [devices]) it publishes status only.
#pragma once

#include <memory>
#include <optional>

#include "cairn.h"
#include "common/dds/topics.hpp"
#include "common/nav_state.hpp"
#include "firmware/executive/executive.hpp"
#include "firmware/global_map.hpp"
#include "firmware/robot_config.hpp"

namespace cairn::firmware {

struct BridgeCounters {
  std::uint64_t odometry = 0, lasers = 0, features = 0, statuses = 0, corrections = 0, tasks = 0, write_failures = 0;
  std::uint64_t invalid_inputs = 0;  // samples from the base that had to be clamped
  std::uint64_t resets = 0;          // SafetyReset samples for this robot
  std::uint64_t remote_stops = 0;    // SafetyStop samples for this robot or for every robot (id 0)
  std::uint64_t bids = 0;
};

/// A MapTile sample as the robot's GlobalMap takes it (the edge's one conversion; the
/// sample must outlive the view).
inline TileView map_tile_view(const cairn_MapTile& t) {
  return {t.tile_x, t.tile_y, static_cast<double>(t.resolution), t.origin_x, t.origin_y, std::span<const std::uint8_t>(t.cells)};
}

class RobotBridge {
 public:
  RobotBridge(const dds::Participant& pp, const RobotConfig& cfg);
  /// Writes whatever the executive queued. Returns the number of samples written.
  std::size_t forward(Executive& exec);
  /// Fills and writes RobotStatus (exec may be null: status-only robot).
  void publish_status(Executive* exec, Nanos now);
  /// What the navigation reports in the next RobotStatus (firmware/nav_monitor.hpp).
  void set_nav(NavState state, std::uint32_t task_id) {
    status_.nav_state = static_cast<std::uint8_t>(state);
    status_.nav_task_id = task_id;
  }
  /// Takes this robot's PoseCorrection and TaskAssignment samples; returns true when any
  /// arrived (the link is alive). `on_task` is called for each task.
  template <typename OnTask>
  bool poll_inputs(OnTask&& on_task);
  /// Takes this robot's SafetyReset samples; each becomes one exec->request_reset()
  /// (exec may be null: taken and dropped). Returns how many arrived.
  std::size_t take_resets(Executive* exec);
  /// Takes the base's SafetyStop samples for this robot or for every robot (id 0); each
  /// becomes one exec->request_remote_stop() (exec may be null). Returns how many arrived.
  std::size_t take_stops(Executive* exec);
  /// Takes the base's MapTile samples (the global map, robot_id 0) into global_map().
  /// Returns how many were stored.
  std::size_t take_map_tiles();
  const GlobalMap& global_map() const { return global_map_; }
  /// Writes this robot's frontier bid.
  void publish_bid(const msg::Bid& bid);
  /// The latest local->global transform from the base station, if any.
  const std::optional<Pose2>& local_to_global() const { return local_to_global_; }
  /// Tells the base the robot left on purpose (it shows "left", not "lost").
  void dispose();
  const BridgeCounters& counters() const { return counters_; }
  const cairn_RobotStatus& status() const { return status_; }

 private:
  template <typename T>
  void write(dds::Writer<T>& w, const T& sample, std::uint64_t* count);

  const RobotConfig& cfg_;
  dds::Topic<cairn_RobotStatus> status_topic_;
  dds::Topic<cairn_OdometryIncrement> odom_topic_;
  dds::Topic<cairn_LaserScan> laser_topic_;
  dds::Topic<cairn_FeatureObservations> feat_topic_;
  dds::Topic<cairn_PoseCorrection> corr_topic_;
  dds::Topic<cairn_TaskAssignment> task_topic_;
  dds::Topic<cairn_SafetyReset> reset_topic_;
  dds::Topic<cairn_SafetyStop> stop_topic_;
  dds::Topic<cairn_MapTile> tile_topic_;
  dds::Topic<cairn_Bid> bid_topic_;
  dds::Writer<cairn_RobotStatus> status_writer_;
  dds::Writer<cairn_OdometryIncrement> odom_writer_;
  dds::Writer<cairn_LaserScan> laser_writer_;
  dds::Writer<cairn_FeatureObservations> feat_writer_;
  dds::Reader<cairn_PoseCorrection> corr_reader_;
  dds::Reader<cairn_TaskAssignment> task_reader_;
  dds::Reader<cairn_SafetyReset> reset_reader_;
  dds::Reader<cairn_SafetyStop> stop_reader_;
  dds::Reader<cairn_MapTile> tile_reader_;
  dds::Writer<cairn_Bid> bid_writer_;
  GlobalMap global_map_;
  cairn_RobotStatus status_{};
  // Conversion buffers, reserved once (a LaserScan is ~3 KB).
  std::unique_ptr<msg::LaserScan> laser_ = std::make_unique<msg::LaserScan>();
  std::unique_ptr<msg::FeatureObservations> feat_ = std::make_unique<msg::FeatureObservations>();
  std::unique_ptr<cairn_LaserScan> laser_dds_ = std::make_unique<cairn_LaserScan>();
  std::unique_ptr<cairn_FeatureObservations> feat_dds_ = std::make_unique<cairn_FeatureObservations>();
  std::unique_ptr<cairn_Bid> bid_dds_ = std::make_unique<cairn_Bid>();
  std::optional<Pose2> local_to_global_;
  bool ever_ready_ = false;
  BridgeCounters counters_;
};

template <typename OnTask>
bool RobotBridge::poll_inputs(OnTask&& on_task) {
  bool heard = false;
  corr_reader_.take([&](const cairn_PoseCorrection& c, const dds_sample_info_t&) {
    if (c.robot_id != cfg_.id) return;
    const Pose2 t{c.local_to_global.x, c.local_to_global.y, c.local_to_global.theta};
    if (std::isfinite(t.x) && std::isfinite(t.y) && std::isfinite(t.theta)) local_to_global_ = t;
    ++counters_.corrections;
    heard = true;
  });
  task_reader_.take([&](const cairn_TaskAssignment& t, const dds_sample_info_t&) {
    if (t.robot_id != cfg_.id) return;
    ++counters_.tasks;
    heard = true;
    msg::TaskAssignment task;
    if (!dds::from_dds(t, &task)) ++counters_.invalid_inputs;  // clamped; an unknown kind became STOP
    on_task(task);
  });
  return heard;
}

}  // namespace cairn::firmware
