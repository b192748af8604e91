// The robot executive: device I/O threads (laser, CAN drives, power board), one periodic
// RT loop (odometry, local scan matching, features, safety, wheel commands), and
// lock-free hand-over to the non-RT side (DDS bridge, path follower), which calls the
// pop_*/set_velocity/note_link methods from one thread. Every buffer is reserved in the
// constructor from the configuration; after start() the RT loop and the I/O threads do
// not allocate, share no lock with the non-RT side, and block only in their own device
// read or their own periodic sleep.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "cairn.h"
#include "common/latest_box.hpp"
#include "common/se2.hpp"
#include "common/spsc_queue.hpp"
#include "drivers/canopen/diff_drive.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "drivers/modbus/power_board.hpp"
#include "drivers/sick/lms_driver.hpp"
#include "firmware/executive/features.hpp"
#include "firmware/executive/loop_stats.hpp"
#include "firmware/executive/odometry.hpp"
#include "firmware/executive/rt_setup.hpp"
#include "firmware/executive/safety.hpp"
#include "firmware/localmap/local_mapper.hpp"

namespace cairn::firmware {

struct ExecutiveConfig {
  std::uint16_t robot_id = 1;
  // Devices.
  std::string lms_uri;
  lms::LmsDriverConfig lms;
  Pose2 laser_mount{0.2, 0.0, 0.0};
  std::string can_uri;
  canopen::MasterConfig master;
  canopen::DiffDriveGeometry geometry;
  std::string power_uri;
  modbus::RegisterMap power_map;
  Nanos power_response_timeout = 50 * kNanosPerMilli;
  Nanos estop_poll = 5 * kNanosPerMilli;
  Nanos power_poll = 500 * kNanosPerMilli;
  // RT loop.
  Nanos period = 10 * kNanosPerMilli;
  RtRequest rt_loop{80, -1, true};
  RtRequest io_threads{70, -1, false};
  // Estimation and outputs.
  OdometryNoise odometry;
  localmap::LocalMapConfig localmap;
  FeatureConfig features;
  int scan_publish_every = 10;
  std::size_t scan_queue = 8, odometry_queue = 256, laser_queue = 4, feature_queue = 32;
  std::size_t odometry_history = 64;  // wheel steps kept to split odometry at a scan's time (>= scan latency / period)
  SafetyLimits safety;
};

/// Device snapshot for RobotStatus (copied out of each I/O thread, ~10 Hz).
struct DeviceSnapshot {
  std::array<char, 16> name{};
  std::uint8_t state = 0;
  std::array<char, 64> reason{};
  std::uint32_t frames = 0, crc_errors = 0, resyncs = 0, timeouts = 0, recoveries = 0, errors = 0;
};

struct RtSnapshot {
  Pose2 local_pose;
  StopReason stop = StopReason::kDrivesNotReady;
  double v = 0, w = 0;
  float period_mean_us = 0, period_p99_us = 0, jitter_max_us = 0;
  std::uint64_t cycles = 0, misses = 0, overflows = 0, scans = 0, matched = 0, stops = 0;
  std::uint64_t publish_drops = 0;
  bool estop = false;
  double battery_voltage = 0, battery_soc = 0;
};

/// Called on each RT/I-O thread when it reaches steady state and when it ends (tests
/// count allocations between the two).
struct ThreadHooks {
  void (*steady)(const char* thread) = nullptr;
  void (*finished)(const char* thread) = nullptr;
};

class Executive {
 public:
  /// Opens the CAN port and the power board (throws std::runtime_error with the device's
  /// URI and reason when one cannot be opened); the laser's link is opened by its I/O
  /// thread and retried, as the driver does.
  explicit Executive(const ExecutiveConfig& cfg, ThreadHooks hooks = {});
  ~Executive();
  Executive(const Executive&) = delete;
  Executive& operator=(const Executive&) = delete;

  void start();
  void stop();
  /// What the RT setup achieved per thread ("rt: SCHED_FIFO refused ..."); each thread
  /// writes its own line as it starts: read after stop().
  const std::array<std::string, 4>& rt_reports() const { return rt_reports_; }

  // Non-RT side (one thread).
  void set_velocity(double v, double w, Nanos now);
  void note_link(Nanos now) { last_link_.store(now, std::memory_order_release); }
  bool pop_odometry(cairn_OdometryIncrement* out) { return odometry_q_.pop(out); }
  bool pop_laser(cairn_LaserScan* out) { return laser_q_.pop(out); }
  bool pop_features(cairn_FeatureObservations* out) { return feature_q_.pop(out); }
  RtSnapshot rt_snapshot();
  std::size_t devices(std::array<DeviceSnapshot, 4>* out);

 private:
  struct Velocity {
    double v = 0, w = 0;
    Nanos stamp = -1;
  };
  struct WheelState {
    std::int32_t left = 0, right = 0;
    std::uint64_t updates = 0;
    bool enabled = false;
    Nanos stamp = 0;  // when these positions arrived
  };
  struct TimedStep {
    Nanos t0 = 0;  // the previous wheel sample: the step covers (t0, t]
    Nanos t = 0;
    OdometryStep step;
  };
  OdometryStep odometry_until(Nanos t);
  OdometryStep odometry_pending() const;
  struct Sink : lms::ScanSink {
    Executive* self = nullptr;
    void on_scan(const lms::LmsScan& s) override;
  };
  void lms_thread();
  void can_thread();
  void power_thread();
  void rt_thread();
  void rt_cycle(Nanos now, double dt);
  void process_scan(const lms::LmsScan& scan);

  ExecutiveConfig cfg_;
  ThreadHooks hooks_;
  std::array<std::string, 4> rt_reports_;
  std::atomic<bool> running_{false};
  std::unique_ptr<can::Port> can_port_;
  std::unique_ptr<canopen::DriveMaster> master_;
  std::unique_ptr<modbus::PowerBoard> power_;
  Sink sink_;
  SpscQueue<lms::LmsScan> scan_q_;
  SpscQueue<cairn_OdometryIncrement> odometry_q_;
  SpscQueue<cairn_LaserScan> laser_q_;
  SpscQueue<cairn_FeatureObservations> feature_q_;
  LatestBox<Velocity> velocity_;
  LatestBox<WheelState> wheels_;
  LatestBox<canopen::WheelCommand> wheel_cmd_;
  LatestBox<modbus::PowerState> power_state_;
  LatestBox<RtSnapshot> rt_box_;
  std::array<LatestBox<DeviceSnapshot>, 4> device_box_;
  std::atomic<Nanos> last_link_{-1}, last_scan_{-1}, last_power_{-1};
  std::atomic<bool> estop_{false}, enable_request_{false};
  std::atomic<std::uint64_t> publish_drops_{0};
  // RT-loop state (touched only by the RT thread after start).
  localmap::LocalMapper mapper_;
  DiffOdometry odometry_;
  SafetySupervisor safety_;
  // Wheel odometry since the last scan: steps older than the ring folded into `folded_`,
  // then the ring (oldest first). A scan takes the steps up to its own time.
  OdometryStep folded_;
  std::unique_ptr<TimedStep[]> steps_;
  std::size_t steps_head_ = 0, steps_count_ = 0;
  Nanos last_wheel_stamp_ = -1;
  Pose2 published_pose_;
  std::unique_ptr<Vec2[]> points_;
  std::unique_ptr<lms::LmsScan> scan_work_;
  std::unique_ptr<cairn_LaserScan> laser_msg_;
  std::unique_ptr<cairn_FeatureObservations> feature_msg_;
  ScanFeatures features_;
  std::uint32_t odom_seq_ = 0, laser_seq_ = 0, feature_seq_ = 0, scans_seen_ = 0;
  Nanos last_odom_t_ = 0;
  bool was_estop_ = false;
  RtSnapshot snap_;
  std::thread threads_[4];
};

}  // namespace cairn::firmware
