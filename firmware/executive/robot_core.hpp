// The robot pipeline without threads, devices or a clock: wheel odometry split at each
// scan's mid-sweep, local scan matching, retroreflective features, safety and the wheel
// command. Time arrives with every call. The threaded Executive runs one on its RT thread
// (cairn-robot, the HIL bench); cairn-sim runs many on simulated time. Every buffer is
// reserved in the constructor; after that nothing allocates. Emits Cairn's own messages
// (common/messages.hpp) to a RobotOutputs; DDS is the caller's business.
#pragma once

#include <cstdint>
#include <memory>

#include "common/messages.hpp"
#include "common/ring_buffer.hpp"
#include "firmware/executive/executive_config.hpp"

namespace cairn::firmware {

/// The latest wheel positions, as the CAN side sees them.
struct WheelReading {
  std::int32_t left = 0, right = 0;  // encoder increments
  std::uint64_t updates = 0;
  bool enabled = false;  // every drive operation enabled
  Nanos stamp = 0;       // when these positions arrived (a new stamp = a new sample)
  Nanos feedback_stamp = -1;  // the oldest of the drives' newest TPDO arrivals (-1: none yet)
  Nanos pass = -1;            // when the CAN thread wrote this reading (its liveness)
};

/// What one control cycle reads besides the wheels.
struct ControlInputs {
  Nanos now = 0;
  bool estop = false;
  Nanos last_link = -1, last_power = -1;  // -1: never
  double v = 0, w = 0;                    // requested velocity
  Nanos command_stamp = -1;               // when it was requested
  bool reset = false;                     // an e-stop reset was requested since the last cycle
  bool remote_stop = false;               // a remote e-stop (SafetyStop) arrived since the last cycle
};

class RobotOutputs {
 public:
  virtual ~RobotOutputs() = default;
  virtual void odometry(const msg::OdometryIncrement& m) = 0;
  virtual void laser(const msg::LaserScan& m) = 0;
  virtual void features(const msg::FeatureObservations& m) = 0;
};

struct CoreCounters {
  std::uint64_t scans = 0, matched = 0;
};

class RobotCore {
 public:
  explicit RobotCore(const ExecutiveConfig& cfg);

  /// A wheel sample; ignored unless its stamp is new.
  void on_wheels(const WheelReading& w);
  /// Processes one scan at `now`: OdometryIncrement always, every Nth LaserScan, and the
  /// FeatureObservations when any feature was seen, to `out`.
  void on_scan(const lms::LmsScan& scan, Nanos now, RobotOutputs& out);
  /// Safety and the wheel command for this cycle (dt: the control period in seconds).
  canopen::WheelCommand control(const ControlInputs& in, double dt);

  /// Corrected local pose now: the last scan's pose with the odometry since.
  Pose2 local_pose() const;
  StopReason stop() const { return stop_; }
  std::uint64_t stops() const { return safety_.stops(); }
  double v() const { return v_; }
  double w() const { return w_; }
  bool drives_enabled() const { return drives_enabled_; }
  /// The e-stop latch (SafetySupervisor): drives disabled and motor power off while set.
  const SafetySupervisor& safety() const { return safety_; }
  /// The protective field's limit in the last control cycle.
  const FieldLimit& field() const { return field_limit_; }
  Nanos last_scan() const { return last_scan_; }
  CoreCounters counters() const;
  localmap::LocalMapper& mapper() { return mapper_; }
  const ExecutiveConfig& config() const { return cfg_; }

 private:
  struct TimedStep {
    Nanos t0 = 0;  // the previous wheel sample: the step covers (t0, t]
    Nanos t = 0;
    OdometryStep step;
  };
  OdometryStep odometry_until(Nanos t);
  OdometryStep odometry_pending() const;

  ExecutiveConfig cfg_;
  localmap::LocalMapper mapper_;
  DiffOdometry odometry_;
  SafetySupervisor safety_;
  ProtectiveField field_;
  FieldLimit field_limit_;
  // Wheel odometry since the last scan: steps older than the ring folded into `folded_`,
  // then the ring (oldest first). A scan takes the steps up to its own time.
  OdometryStep folded_;
  RingBuffer<TimedStep> steps_;  // full: the caller folds the oldest first
  Nanos last_wheel_stamp_ = -1;
  bool drives_enabled_ = false;
  Nanos last_feedback_ = -1, last_can_pass_ = -1;
  std::unique_ptr<Vec2[]> points_;
  std::unique_ptr<msg::LaserScan> laser_msg_;
  std::unique_ptr<msg::FeatureObservations> feature_msg_;
  ScanFeatures features_;
  std::uint32_t odom_seq_ = 0, laser_seq_ = 0, feature_seq_ = 0, scans_seen_ = 0;
  Nanos last_odom_t_ = 0, last_scan_ = -1;
  Nanos last_feature_stamp_ = 0;  // stamp of the last scan whose features went out
  bool features_sent_ = false;
  StopReason stop_ = StopReason::kDrivesNotReady;
  double v_ = 0, w_ = 0;
};

}  // namespace cairn::firmware
