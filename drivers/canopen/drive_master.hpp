// The CANopen master for a robot's CiA 402 drives: brings each node from boot-up to
// "operation enabled" (SDO configuration of heartbeat, mode and PDO mapping, NMT start,
// 402 enabling through RPDO1), produces SYNC, consumes heartbeats, reads TPDOs, decodes
// EMCY, and recovers with bounded back-off from faults, node loss and bus-off. While any
// drive is not operation enabled, every drive is commanded zero velocity. Each transition
// is recorded with its reason. step() never blocks longer than `io_slice`.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <span>

#include "common/ring_buffer.hpp"
#include "drivers/can/can_port.hpp"
#include "drivers/canopen/cia402.hpp"
#include "drivers/canopen/sdo_client.hpp"

namespace cairn::canopen {

inline constexpr std::size_t kMaxDrives = 4;
inline constexpr int kMaxFramesPerStep = 64;  // frames handled per step(): a bounded loop

struct MasterConfig {
  std::array<std::uint8_t, kMaxDrives> nodes{1, 2, 0, 0};  // 0 = unused
  Nanos sync_period = 10 * kNanosPerMilli;
  std::uint16_t heartbeat_ms = 50;                 // drives' producer period (0x1017)
  Nanos heartbeat_timeout = 110 * kNanosPerMilli;  // consumer: > 2 periods
  Nanos boot_timeout = 2 * kNanosPerSecond;        // no boot-up / heartbeat: reset the node
  Nanos sdo_timeout = 100 * kNanosPerMilli;
  int sdo_retries = 3;
  Nanos recovery_backoff = 200 * kNanosPerMilli;   // first retry; doubles up to max
  Nanos recovery_backoff_max = 2 * kNanosPerSecond;
  cia402::Mode mode = cia402::Mode::kCyclicSyncVelocity;
  cia402::Quirks quirks;
  Nanos io_slice = 2 * kNanosPerMilli;
};

enum class NodePhase : std::uint8_t { kWaitBoot, kConfigure, kStart, kEnable, kEnabled, kLost, kFault };
const char* phase_name(NodePhase p);

struct DriveFeedback {
  std::uint16_t statusword = 0;
  std::int32_t velocity = 0;   // increments/s (0x606C)
  std::int32_t position = 0;   // increments (0x6064)
  Nanos stamp = 0;             // when the TPDO arrived
  std::uint64_t updates = 0;
};

struct TransitionEvent {
  Nanos time = 0;
  std::uint8_t node = 0;
  NodePhase to = NodePhase::kWaitBoot;
  std::array<char, 72> reason{};
};

class DriveMaster {
 public:
  DriveMaster(can::Port* port, Clock* clock, const MasterConfig& cfg);

  /// One bounded step: receive, supervise, produce SYNC and RPDOs when due.
  void step();
  /// Target velocities (increments/s) per drive slot; applied only while all are enabled.
  void command(std::span<const std::int32_t> velocities);
  /// Immediately command zero and disable operation (call from the master's own thread).
  void disable_all(const char* reason);
  /// The e-stop fast path, callable from any thread without a lock: the master's next
  /// step() (within io_slice) disables every drive and sends it at once.
  void request_estop() { estop_request_.store(true, std::memory_order_release); }
  void enable_all();

  bool all_enabled() const;
  NodePhase phase(std::size_t slot) const { return nodes_[slot].phase; }
  cia402::State drive_state(std::size_t slot) const { return cia402::decode(nodes_[slot].feedback.statusword); }
  const DriveFeedback& feedback(std::size_t slot) const { return nodes_[slot].feedback; }
  std::int32_t commanded(std::size_t slot) const { return nodes_[slot].sent_velocity; }
  std::uint16_t last_emcy(std::size_t slot) const { return nodes_[slot].last_emcy; }
  /// Transitions, oldest first (a fixed ring of the last 64).
  std::size_t event_count() const { return events_.size(); }
  const TransitionEvent& event(std::size_t i) const;
  std::uint64_t syncs() const { return syncs_; }
  std::uint64_t recoveries() const { return recoveries_; }
  /// Bus-off restarts of the port that failed (each retried after recovery_backoff).
  std::uint64_t restart_failures() const { return restart_failures_; }
  /// Steps that found a full kMaxFramesPerStep frames waiting and slept out their slice.
  std::uint64_t floods() const { return floods_; }
  /// Frames the port did not send (queue full past the slice, an error); bus-off and a
  /// down link are the port's own counts.
  std::uint64_t send_failures() const { return send_failures_; }

 private:
  struct Node {
    std::uint8_t id = 0;
    NodePhase phase = NodePhase::kWaitBoot;
    SdoClient sdo{0, 0, 0};
    int config_step = 0;
    Nanos phase_since = 0, last_heartbeat = 0, retry_at = 0, backoff = 0;
    NmtState nmt = NmtState::kBootUp;
    DriveFeedback feedback;
    std::int32_t target = 0, sent_velocity = 0;
    std::uint16_t last_cw = 0;
    std::uint16_t last_emcy = 0;
  };
  void set_phase(Node& n, NodePhase p, const char* reason);
  void dispatch(const can::Frame& f, Nanos now);
  void supervise(Node& n, Nanos now);
  bool next_config(Node& n);
  void send_sync_cycle(Nanos now);
  void send(const can::Frame& f);

  can::Port* port_;
  Clock* clock_;
  MasterConfig cfg_;
  std::array<Node, kMaxDrives> nodes_;
  std::size_t count_ = 0;
  Nanos next_sync_ = 0;
  std::uint64_t syncs_ = 0, recoveries_ = 0, restart_failures_ = 0, floods_ = 0, send_failures_ = 0;
  bool disabled_ = false;
  std::atomic<bool> estop_request_{false};
  Nanos bus_retry_at_ = 0;
  RingBuffer<TransitionEvent> events_{64, WhenFull::kOverwriteOldest};
};

}  // namespace cairn::canopen
