// The robot executive: device I/O threads (laser, CAN drives, power board) and one RT
// thread that runs the RobotCore (odometry, local scan matching, features, safety, wheel
// commands), with lock-free hand-over to the non-RT side (DDS bridge, path follower),
// which calls the pop_*/set_velocity/note_link methods from one thread. The caller hands
// it its clock and its opened devices (firmware/executive/devices.hpp opens them from
// URIs). The RT thread wakes when a scan arrives (processed at once) and at each control
// period; each output wakes the non-RT side through output_event(). A keyframe's rebuild
// of the likelihood field runs on a lower-priority worker thread into a second grid, which
// the RT thread swaps in (localmap async_rebuild); matching goes on meanwhile. Every buffer is
// reserved in the constructor; after start() the RT loop and the I/O threads do not
// allocate, share no lock with the non-RT side, and block only in their own device read
// or their own wait.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "common/event_count.hpp"
#include "common/latest_box.hpp"
#include "common/messages.hpp"
#include "common/se2.hpp"
#include "common/spsc_queue.hpp"
#include "drivers/can/can_port.hpp"
#include "drivers/modbus/power_link.hpp"
#include "drivers/serial/byte_stream.hpp"
#include "firmware/executive/executive_config.hpp"
#include "firmware/executive/loop_stats.hpp"
#include "firmware/executive/robot_core.hpp"

namespace cairn::firmware {

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
  Vec2 field_nearest{0, 0};  // the return limiting the protective field (robot frame), when field_limited
  bool field_limited = false;
  float period_mean_us = 0, period_p99_us = 0, jitter_max_us = 0;
  float scan_work_p99_us = 0, scan_work_max_us = 0;  // one scan's processing on the RT thread
  std::uint64_t cycles = 0, misses = 0, overflows = 0, scans = 0, matched = 0, stops = 0;
  std::array<LoopStats::Miss, LoopStats::kMissLog> first_misses{};  // the first min(misses, 8)
  std::uint64_t publish_drops = 0;
  bool estop = false;
  bool latched = false;        // the e-stop latch: drives disabled, motor power off until a reset
  LatchCause latch_cause = LatchCause::kNone;
  bool motor_power = false;    // what the executive asks of the board's motor relay
  std::uint64_t resets_accepted = 0, resets_refused = 0;
  std::uint32_t remote_stops = 0;       // remote e-stops taken (RobotStatus.remote_stops)
  std::uint64_t resets_predating = 0;   // network resets refused: they predate a remote e-stop
  double battery_voltage = 0, battery_soc = 0;
};

/// Called on each RT/I-O thread when it reaches steady state and when it ends (tests
/// count allocations between the two).
struct ThreadHooks {
  void (*steady)(const char* thread) = nullptr;
  void (*finished)(const char* thread) = nullptr;
};

/// The robot's devices, opened by the caller (devices.hpp opens them from the URIs).
struct ExecutiveDevices {
  std::unique_ptr<serial::ByteStream> laser;
  std::unique_ptr<can::Port> can;
  std::unique_ptr<modbus::PowerLink> power;
};

class Executive {
 public:
  /// Takes the devices (all three required: std::invalid_argument otherwise) and the
  /// clock every thread reads and waits on.
  Executive(const ExecutiveConfig& cfg, Clock& clock, ExecutiveDevices devices, ThreadHooks hooks = {});
  ~Executive();
  Executive(const Executive&) = delete;
  Executive& operator=(const Executive&) = delete;

  void start();
  void stop();
  /// What the RT setup achieved per thread ("rt: SCHED_FIFO refused ..."); each thread
  /// writes its own line as it starts: read after stop().
  const std::array<std::string, 5>& rt_reports() const { return rt_reports_; }

  // Non-RT side (one thread).
  void set_velocity(double v, double w, Nanos now);
  void note_link(Nanos now) { last_link_.store(now, std::memory_order_release); }
  /// An explicit e-stop reset (the base's SafetyReset, SIGUSR1, ...), from any thread: the
  /// RT loop's next cycle accepts it if the e-stop reads released, the power board answers
  /// and the CAN thread cycles; otherwise it is refused (counted) and forgotten.
  void request_reset() { reset_requests_.fetch_add(1, std::memory_order_acq_rel); }
  /// An operator's reset over the network (the base's SafetyReset), from any thread: refused
  /// (false, counted) when it has not seen every remote e-stop taken so far, i.e. it was
  /// asked for before the latest of them (topics are not ordered with each other, and the
  /// base resends); otherwise request_reset().
  bool request_reset(std::uint32_t remote_stops_seen);
  /// An operator's remote e-stop (the base's SafetyStop), from any thread: torque off at
  /// once (the drive master's lock-free request), motor power off, and the RT loop's next
  /// cycle latches (cause "remote e-stop") until a reset.
  void request_remote_stop();
  bool pop_odometry(msg::OdometryIncrement* out) { return odometry_q_.pop(out); }
  bool pop_laser(msg::LaserScan* out) { return laser_q_.pop(out); }
  bool pop_features(msg::FeatureObservations* out) { return feature_q_.pop(out); }
  /// Moves each time the RT thread queues an output: the non-RT side waits on it.
  const EventCount& output_event() const { return output_event_; }
  /// Non-RT side: something is queued (check after reading output_event().value()).
  bool has_output() { return odometry_q_.front() || feature_q_.front() || laser_q_.front(); }
  Clock& clock() { return clock_; }
  RtSnapshot rt_snapshot();
  std::size_t devices(std::array<DeviceSnapshot, 4>* out);

 private:
  struct Velocity {
    double v = 0, w = 0;
    Nanos stamp = -1;
  };
  struct Sink : lms::ScanSink {
    Executive* self = nullptr;
    void on_scan(const lms::LmsScan& s) override;
  };
  /// The RT thread's outputs into the queues for the non-RT side.
  struct QueueOutputs : RobotOutputs {
    Executive* self = nullptr;
    void odometry(const msg::OdometryIncrement& m) override;
    void laser(const msg::LaserScan& m) override;
    void features(const msg::FeatureObservations& m) override;
  };
  void lms_thread();
  void can_thread();
  void power_thread();
  void rt_thread();
  void map_worker_thread();
  void control_cycle(Nanos now, double dt);

  ExecutiveConfig cfg_;
  Clock& clock_;
  ExecutiveDevices dev_;
  ThreadHooks hooks_;
  std::array<std::string, 5> rt_reports_;
  std::atomic<bool> running_{false};
  std::unique_ptr<canopen::DriveMaster> master_;
  Sink sink_;
  QueueOutputs outputs_;
  SpscQueue<lms::LmsScan> scan_q_;
  SpscQueue<msg::OdometryIncrement> odometry_q_;
  SpscQueue<msg::LaserScan> laser_q_;
  SpscQueue<msg::FeatureObservations> feature_q_;
  EventCount scan_event_, output_event_, rebuild_event_;
  LatestBox<Velocity> velocity_;
  LatestBox<WheelReading> wheels_;
  LatestBox<canopen::WheelCommand> wheel_cmd_;
  LatestBox<modbus::PowerState> power_state_;
  LatestBox<RtSnapshot> rt_box_;
  std::array<LatestBox<DeviceSnapshot>, 4> device_box_;
  std::atomic<Nanos> last_link_{-1}, last_power_{-1};
  std::atomic<bool> estop_{false}, enable_request_{false};
  std::atomic<bool> motor_power_want_{true};      // RT -> power thread (off while latched)
  std::atomic<std::uint32_t> reset_requests_{0};  // any thread -> RT (a count: edges are not lost)
  std::atomic<std::uint32_t> estop_presses_{0};   // power thread -> RT
  std::atomic<std::uint32_t> remote_stops_{0};    // any thread -> RT (a count: a stop is never lost)
  std::atomic<std::uint64_t> resets_predating_{0};
  std::atomic<std::uint64_t> publish_drops_{0};
  // RT-thread state (touched only by the RT thread after start).
  RobotCore core_;
  std::unique_ptr<lms::LmsScan> scan_work_;
  bool was_latched_ = false;
  std::uint32_t resets_seen_ = 0, presses_seen_ = 0, remote_stops_seen_ = 0;
  RtSnapshot snap_;
  std::thread threads_[5];
};

}  // namespace cairn::firmware
