#include "drivers/canopen/drive_master.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "drivers/canopen/object_dictionary.hpp"
#include "drivers/canopen/pdo_map.hpp"

namespace cairn::canopen {

namespace {
// The process data, from the one table: the fields to pack and unpack, and where each value sits.
constexpr PdoFields kRpdo1Fields = pdo_fields(pdo_map::kRpdo1);
constexpr PdoFields kTpdo1Fields = pdo_fields(pdo_map::kTpdo1);
constexpr PdoFields kTpdo2Fields = pdo_fields(pdo_map::kTpdo2);
constexpr std::size_t kControlwordSlot = slot(pdo_map::kRpdo1, od::kControlword);
constexpr std::size_t kTargetVelocitySlot = slot(pdo_map::kRpdo1, od::kTargetVelocity);
constexpr std::size_t kStatuswordSlot = slot(pdo_map::kTpdo1, od::kStatusword);
constexpr std::size_t kVelocityActualSlot = slot(pdo_map::kTpdo1, od::kVelocityActual);
constexpr std::size_t kPositionActualSlot = slot(pdo_map::kTpdo2, od::kPositionActual);
static_assert(kControlwordSlot < kMaxMappedObjects && kTargetVelocitySlot < kMaxMappedObjects && kStatuswordSlot < kMaxMappedObjects &&
                  kVelocityActualSlot < kMaxMappedObjects && kPositionActualSlot < kMaxMappedObjects,
              "the master reads and writes these objects: the table must map them");
}  // namespace

const char* phase_name(NodePhase p) {
  switch (p) {
    case NodePhase::kWaitBoot: return "waiting for boot-up";
    case NodePhase::kConfigure: return "configuring";
    case NodePhase::kStart: return "starting";
    case NodePhase::kEnable: return "enabling";
    case NodePhase::kEnabled: return "operation enabled";
    case NodePhase::kLost: return "lost";
    case NodePhase::kFault: return "fault";
  }
  return "?";
}

DriveMaster::DriveMaster(can::Port* port, Clock* clock, const MasterConfig& cfg) : port_(port), clock_(clock), cfg_(cfg) {
  const Nanos now = clock_->now();
  for (std::uint8_t id : cfg_.nodes) {
    if (!id || count_ >= kMaxDrives) continue;
    Node& n = nodes_[count_++];
    n.id = id;
    n.sdo = SdoClient(id, cfg_.sdo_timeout, cfg_.sdo_retries);
    n.phase_since = now;
    n.backoff = cfg_.recovery_backoff;
    // A node that booted before us sends no boot-up: ask every node to reset communication.
  }
  send(nmt(NmtCommand::kResetComm, 0));
  next_sync_ = now + cfg_.sync_period;
}

const TransitionEvent& DriveMaster::event(std::size_t i) const { return events_[i]; }

void DriveMaster::set_phase(Node& n, NodePhase p, const char* reason) {
  if (n.phase == p) return;
  n.phase = p;
  n.phase_since = clock_->now();
  TransitionEvent e;
  e.time = n.phase_since;
  e.node = n.id;
  e.to = p;
  std::snprintf(e.reason.data(), e.reason.size(), "%s", reason);
  events_.push(e);  // full: the oldest goes
}

void DriveMaster::send(const can::Frame& f) {
  // Not retried here: SYNC, PDOs and heartbeats go out again next cycle, and an SDO the
  // drive does not answer is retried by its client. Counted, and reported as bus errors;
  // not while the bus is off or the link down, which the port counts once per incident
  // (every frame of every cycle would otherwise count again).
  const can::SendResult r = port_->send(f, clock_->now() + cfg_.io_slice);
  if (r != can::SendResult::kSent && r != can::SendResult::kBusOff && r != can::SendResult::kDown) ++send_failures_;
}

bool DriveMaster::all_enabled() const {
  if (port_->bus_off()) return false;
  for (std::size_t i = 0; i < count_; ++i) {
    if (nodes_[i].phase != NodePhase::kEnabled) return false;
  }
  return count_ > 0;
}

void DriveMaster::command(std::span<const std::int32_t> v) {
  for (std::size_t i = 0; i < count_ && i < v.size(); ++i) nodes_[i].target = v[i];
}

void DriveMaster::disable_all(const char* reason) {
  disabled_ = true;
  for (std::size_t i = 0; i < count_; ++i) {
    nodes_[i].target = 0;
    if (nodes_[i].phase == NodePhase::kEnabled) set_phase(nodes_[i], NodePhase::kEnable, reason);
  }
  send_sync_cycle(clock_->now());  // the zero / disable goes out now, not at the next SYNC
}

void DriveMaster::enable_all() { disabled_ = false; }

// The configuration sequence: heartbeat, mode, then every PDO of pdo_map::kDrive in
// order, each remapped by the standard procedure (remap_write: disable, clear count,
// entries, count, transmission type, enable).
bool DriveMaster::next_config(Node& n) {
  SdoWrite w;
  std::size_t step = static_cast<std::size_t>(n.config_step);
  if (step == 0) {
    w = {{od::kProducerHeartbeat, 0}, cfg_.heartbeat_ms, 2};
  } else if (step == 1) {
    w = {{od::kModesOfOperation, 0}, static_cast<std::uint32_t>(cfg_.mode), 1};
  } else {
    step -= 2;
    const PdoMapping* pdo = nullptr;
    for (const PdoMapping& m : pdo_map::kDrive) {
      if (step < remap_writes(m)) {
        pdo = &m;
        break;
      }
      step -= remap_writes(m);
    }
    if (!pdo) return false;  // configured
    w = remap_write(*pdo, n.id, step);
  }
  n.sdo.download_u32(w.address, w.value, w.size);
  return true;
}

void DriveMaster::dispatch(const can::Frame& f, Nanos now) {
  if (f.is_error()) return;  // bus state is read from the port
  // Only 11-bit data frames are CANopen: an extended or remote frame whose low bits match
  // a node's TPDO must not overwrite its feedback (nor feed its SDO client, ...).
  if (!is_standard_data_frame(f)) return;
  const Classified c = classify(f.id);
  for (std::size_t i = 0; i < count_; ++i) {
    Node& n = nodes_[i];
    if (c.node != n.id) continue;
    switch (c.kind) {
      case Kind::kHeartbeat: {
        const auto hb = decode_heartbeat(f);
        if (!hb) break;
        n.last_heartbeat = now;
        n.nmt = hb->state;
        if (hb->state == NmtState::kBootUp) {
          set_phase(n, NodePhase::kConfigure, "boot-up received: configuring");
          n.config_step = 0;
          n.sdo.reset();
          next_config(n);
        } else if (n.phase == NodePhase::kLost) {
          set_phase(n, NodePhase::kWaitBoot, "heartbeat is back: resetting the node");
          send(nmt(NmtCommand::kResetComm, n.id));
        }
        break;
      }
      case Kind::kSdoResponse:
        n.sdo.on_frame(f, now);
        break;
      case Kind::kEmcy:
        if (const auto e = decode_emcy(f)) {
          n.last_emcy = e->code;
          if (e->code != 0 && n.phase != NodePhase::kFault) {
            char reason[72];
            std::snprintf(reason, sizeof reason, "EMCY 0x%04X: %s", e->code, emcy_text(e->code));
            set_phase(n, NodePhase::kFault, reason);
            n.retry_at = now + n.backoff;
          }
        }
        break;
      case Kind::kTpdo: {
        // Unpacked by the table (a frame shorter than its mapping is refused).
        std::int64_t v[kMaxMappedObjects] = {};
        if (c.pdo == pdo_map::kTpdo1.pdo && unpack_pdo(f, kTpdo1Fields.span(), v)) {
          n.feedback.statusword = static_cast<std::uint16_t>(v[kStatuswordSlot]);
          n.feedback.velocity = static_cast<std::int32_t>(v[kVelocityActualSlot]);
          n.feedback.stamp = f.stamp;
          ++n.feedback.updates;
        } else if (c.pdo == pdo_map::kTpdo2.pdo && unpack_pdo(f, kTpdo2Fields.span(), v)) {
          n.feedback.position = static_cast<std::int32_t>(v[kPositionActualSlot]);
        }
        break;
      }
      default:
        break;
    }
  }
}

void DriveMaster::supervise(Node& n, Nanos now) {
  // Heartbeat consumer (once the node was configured to produce one).
  if (n.phase >= NodePhase::kStart && n.phase <= NodePhase::kFault && n.phase != NodePhase::kLost &&
      now - n.last_heartbeat > cfg_.heartbeat_timeout) {
    set_phase(n, NodePhase::kLost, "heartbeat timeout: commanding zero");
    n.retry_at = now + n.backoff;
    return;
  }
  if (auto f = n.sdo.poll(now)) send(*f);
  switch (n.phase) {
    case NodePhase::kWaitBoot:
      if (now - n.phase_since > cfg_.boot_timeout) {
        set_phase(n, NodePhase::kWaitBoot, "no boot-up: resetting the node again");
        n.phase_since = now;
        send(nmt(NmtCommand::kResetComm, n.id));
      }
      return;
    case NodePhase::kConfigure:
      if (n.sdo.status() == SdoClient::Status::kDone) {
        ++n.config_step;
        n.sdo.reset();
        if (!next_config(n)) {
          set_phase(n, NodePhase::kStart, "configured: starting (NMT)");
          n.last_heartbeat = now;
          send(nmt(NmtCommand::kStart, n.id));
        }
      } else if (n.sdo.status() == SdoClient::Status::kFailed) {
        char reason[72];
        std::snprintf(reason, sizeof reason, "SDO failed: %s", n.sdo.error());
        set_phase(n, NodePhase::kLost, reason);
        n.retry_at = now + n.backoff;
      }
      return;
    case NodePhase::kStart:
      if (n.nmt == NmtState::kOperational) set_phase(n, NodePhase::kEnable, "operational: enabling the drive");
      return;
    case NodePhase::kEnable:
      // Only a statusword received after entering this phase counts (not a stale one).
      if (n.feedback.stamp > n.phase_since && cia402::decode(n.feedback.statusword) == cia402::State::kOperationEnabled &&
          !disabled_ && !port_->bus_off()) {
        set_phase(n, NodePhase::kEnabled, "operation enabled");
        n.backoff = cfg_.recovery_backoff;
      }
      return;
    case NodePhase::kEnabled:
      if (cia402::decode(n.feedback.statusword) != cia402::State::kOperationEnabled) {
        set_phase(n, cia402::decode(n.feedback.statusword) == cia402::State::kFault ? NodePhase::kFault : NodePhase::kEnable,
                  "drive left operation enabled");
        n.retry_at = now + n.backoff;
      }
      return;
    case NodePhase::kFault:
      // Fault reset is attempted by the controlword planner in the SYNC cycle after the back-off.
      if (now >= n.retry_at && cia402::decode(n.feedback.statusword) != cia402::State::kFault) {
        ++recoveries_;
        n.backoff = std::min(n.backoff * 2, cfg_.recovery_backoff_max);
        set_phase(n, NodePhase::kEnable, "fault cleared: enabling");
      }
      return;
    case NodePhase::kLost:
      if (now >= n.retry_at) {
        ++recoveries_;
        n.backoff = std::min(n.backoff * 2, cfg_.recovery_backoff_max);
        n.retry_at = now + n.backoff;
        send(nmt(NmtCommand::kResetComm, n.id));  // a live node answers with boot-up
      }
      return;
  }
}

void DriveMaster::send_sync_cycle(Nanos now) {
  const bool go = all_enabled() && !disabled_;
  for (std::size_t i = 0; i < count_; ++i) {
    Node& n = nodes_[i];
    if (n.phase < NodePhase::kEnable || n.phase == NodePhase::kLost) continue;
    const cia402::State s = cia402::decode(n.feedback.statusword);
    std::uint16_t cw = n.last_cw;
    if (disabled_) {
      cw = cia402::cw::kSwitchOn;  // disable operation: stops the motor, keeps it switched on
    } else if (n.phase == NodePhase::kFault && now < n.retry_at) {
      cw = cia402::cw::kDisableVoltage;
    } else {
      cw = cia402::next_controlword(s, cia402::State::kOperationEnabled, n.last_cw, cfg_.quirks);
    }
    n.sent_velocity = go ? n.target : 0;
    Frame f;
    std::int64_t values[kMaxMappedObjects] = {};
    values[kControlwordSlot] = cw;
    values[kTargetVelocitySlot] = n.sent_velocity;
    pack_pdo(kRpdo1Fields.span(), values, &f);
    f.id = cob_id(pdo_map::kRpdo1, n.id);
    send(f);
    n.last_cw = cw;
  }
  send(sync());
  ++syncs_;
}

void DriveMaster::step() {
  if (estop_request_.exchange(false, std::memory_order_acq_rel)) disable_all("e-stop");
  Nanos now = clock_->now();
  // Bus-off: restart the port with back-off; everything stays commanded zero meanwhile.
  if (port_->bus_off()) {
    if (now >= bus_retry_at_) {
      if (!port_->restart().ok()) ++restart_failures_;
      bus_retry_at_ = now + cfg_.recovery_backoff;
      for (std::size_t i = 0; i < count_; ++i) {
        if (nodes_[i].phase == NodePhase::kEnabled) set_phase(nodes_[i], NodePhase::kEnable, "bus-off: restarting the bus");
      }
    }
  }
  // First drain what is already queued (bounded, so the loop's cost is bounded); only
  // when nothing is there wait for more, until the next SYNC is due or the slice ends.
  can::Frame f;
  int drained = 0;
  while (drained < kMaxFramesPerStep && port_->receive(&f, 0)) {
    dispatch(f, clock_->now());
    ++drained;
  }
  if (drained == 0) {
    const Nanos until = std::min(now + cfg_.io_slice, next_sync_);
    while (!estop_request_.load(std::memory_order_acquire) && port_->receive(&f, std::max<Nanos>(0, until - clock_->now()))) {
      dispatch(f, clock_->now());
      if (++drained >= kMaxFramesPerStep || clock_->now() >= until) break;
    }
  }
  // A flood (a babbling node, a bus full of foreign traffic) never runs out of frames, so
  // the waits above never wait: after a full step's worth the thread sleeps out the rest of
  // its slice (the frames beyond wait in the socket, or overflow it and are counted). Not
  // with an e-stop request waiting, which is acted on below, after the pause.
  if (drained >= kMaxFramesPerStep && !estop_request_.load(std::memory_order_acquire)) {
    ++floods_;
    port_->pause(std::min(now + cfg_.io_slice, next_sync_));
  }
  if (estop_request_.exchange(false, std::memory_order_acq_rel)) disable_all("e-stop");
  now = clock_->now();
  for (std::size_t i = 0; i < count_; ++i) supervise(nodes_[i], now);
  if (now >= next_sync_) {
    next_sync_ += cfg_.sync_period;
    if (next_sync_ < now) next_sync_ = now + cfg_.sync_period;  // fell behind: do not burst
    send_sync_cycle(now);
  }
}

}  // namespace cairn::canopen
