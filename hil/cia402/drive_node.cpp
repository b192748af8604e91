#include "hil/cia402/drive_node.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::hil {

using namespace cairn::canopen;
using cia402::State;

namespace {
constexpr std::uint32_t key(std::uint16_t index, std::uint8_t sub) { return (static_cast<std::uint32_t>(index) << 8) | sub; }
// The modes of operation this drive accepts (0x6060): none, profile velocity, cyclic synchronous velocity.
bool supported_mode(std::uint32_t v) {
  return v == static_cast<std::uint32_t>(cia402::Mode::kNone) || v == static_cast<std::uint32_t>(cia402::Mode::kProfileVelocity) ||
         v == static_cast<std::uint32_t>(cia402::Mode::kCyclicSyncVelocity);
}
}  // namespace

DriveNode::DriveNode(DriveConfig cfg) : cfg_(std::move(cfg)) { reset_communication(); }

void DriveNode::reset_communication() {
  const std::uint8_t n = cfg_.node;
  od_.clear();
  auto def = [&](std::uint16_t i, std::uint8_t s, std::uint32_t v, std::uint8_t size, bool w) { od_[key(i, s)] = {v, size, w}; };
  def(od::kDeviceType, 0, 0xFFFF0192, 4, false);  // low word 0x0192: CiA 402
  def(od::kErrorRegister, 0, 0, 1, false);
  def(od::kProducerHeartbeat, 0, 0, 2, true);
  // The PDOs: this drive's factory mapping is Cairn's (the master remaps them all the same).
  auto def_pdo = [&](const SdoWrite& w) { def(w.address.index, w.address.sub, w.value, w.size, true); };
  for (const PdoMapping& m : pdo_map::kDrive) {
    def_pdo(pdo_cob_id_object(m, n));
    SdoWrite type = pdo_transmission_type_object(m);
    // This drive applies an RPDO on arrival, whatever its type: its factory type says so.
    if (m.direction == PdoDirection::kRpdo) type.value = od::kTransmissionEventDriven;
    def_pdo(type);
    def_pdo(pdo_mapping_count_object(m));
    for (std::size_t i = 0; i < m.count; ++i) def_pdo(pdo_mapping_entry_object(m, i));
  }
  // CiA 402
  def(od::kControlword, 0, 0, 2, true);
  def(od::kStatusword, 0, 0, 2, false);
  def(od::kModesOfOperation, 0, 0, 1, true);
  def(od::kModesOfOperationDisplay, 0, 0, 1, false);
  def(od::kPositionActual, 0, 0, 4, false);
  def(od::kVelocityActual, 0, 0, 4, false);
  def(od::kProfileAcceleration, 0, 400000, 4, true);  // increments/s²
  def(od::kProfileDeceleration, 0, 400000, 4, true);
  def(od::kQuickStopDeceleration, 0, 2000000, 4, true);
  def(od::kTargetVelocity, 0, 0, 4, true);
  def(od::kSupportedDriveModes, 0, od::drive_modes::kProfileVelocity | od::drive_modes::kCyclicSyncVelocity, 4, false);
}

std::uint32_t DriveNode::od(std::uint16_t index, std::uint8_t sub) const {
  auto it = od_.find(key(index, sub));
  return it == od_.end() ? 0 : it->second.value;
}

void DriveNode::set_od(std::uint16_t index, std::uint8_t sub, std::uint32_t v) { od_[key(index, sub)].value = v; }

void DriveNode::power_on(Nanos now) {
  reset_communication();
  nmt_ = NmtState::kBootUp;
  state_ = State::kNotReadyToSwitchOn;
  booted_ = false;
  boot_at_ = now + static_cast<Nanos>(cfg_.boot_time_s * 1e9);
  last_update_ = now;
  velocity_ = 0;
  last_cw_ = 0;
}

std::uint16_t DriveNode::statusword() const {
  std::uint16_t sw = 0;
  switch (state_) {
    case State::kNotReadyToSwitchOn: sw = 0x0000; break;
    case State::kSwitchOnDisabled: sw = 0x0040; break;
    case State::kReadyToSwitchOn: sw = 0x0021; break;
    case State::kSwitchedOn: sw = 0x0023; break;
    case State::kOperationEnabled: sw = 0x0027; break;
    case State::kQuickStopActive: sw = 0x0007; break;
    case State::kFaultReactionActive: sw = 0x000F; break;
    case State::kFault: sw = 0x0008; break;
    case State::kUnknown: break;
  }
  if (state_ != State::kNotReadyToSwitchOn && state_ != State::kSwitchOnDisabled && state_ != State::kFault) sw |= 0x0010;  // voltage
  sw |= 0x0200;                                                                     // remote
  const auto target = static_cast<std::int32_t>(od(od::kTargetVelocity, 0));
  if (std::abs(velocity_ - static_cast<double>(target)) < 100) sw |= 0x0400;  // target reached
  return sw;
}

void DriveNode::handle_controlword(std::uint16_t cw) {
  const bool reset_edge = (cw & 0x80) && !(last_cw_ & 0x80);
  last_cw_ = cw;
  if (cfg_.reject_halt && (cw & cia402::cw::kHalt) && state_ == State::kOperationEnabled) {
    over_current(last_update_);  // the quirk: this drive faults on HALT
    return;
  }
  if (state_ == State::kFault) {
    if (reset_edge) {
      state_ = State::kSwitchOnDisabled;
      set_od(od::kErrorRegister, 0, 0);
      send(encode_emcy(cfg_.node, 0x0000, 0));  // error reset
    }
    return;
  }
  if (state_ == State::kNotReadyToSwitchOn || state_ == State::kFaultReactionActive) return;
  if ((cw & 0x0002) == 0) {  // disable voltage
    state_ = State::kSwitchOnDisabled;
    return;
  }
  if ((cw & 0x0006) == 0x0002) {  // quick stop
    state_ = state_ == State::kOperationEnabled ? State::kQuickStopActive : State::kSwitchOnDisabled;
    return;
  }
  switch (cw & 0x000F) {
    case 0x6:
      if (state_ != State::kQuickStopActive) state_ = State::kReadyToSwitchOn;
      break;
    case 0x7:
      if (state_ == State::kReadyToSwitchOn || state_ == State::kOperationEnabled) state_ = State::kSwitchedOn;
      break;
    case 0xF:
      if (state_ == State::kSwitchedOn || state_ == State::kOperationEnabled || state_ == State::kQuickStopActive) {
        state_ = State::kOperationEnabled;
      }
      break;
    default:
      break;
  }
}

void DriveNode::inject_garbage(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::uint32_t own[] = {kCobTpdo[0] + cfg_.node, kCobTpdo[1] + cfg_.node, kCobHeartbeat + cfg_.node, kCobEmcy + cfg_.node,
                               kCobSdoTx + cfg_.node};
  for (std::size_t i = 0; i < n; ++i) {
    Frame f;
    if (i % 2) {
      f.id = 0x7E0 + static_cast<std::uint32_t>(rng() % 0x1F);  // foreign traffic outside CANopen's node range
      f.len = static_cast<std::uint8_t>(rng() % 9);
    } else {
      f.id = own[rng() % 5];
      f.len = static_cast<std::uint8_t>(1 + rng() % 3);  // too short for any of them (SDO 8, EMCY 8, TPDO 4/6)
      if (f.id == kCobHeartbeat + cfg_.node) f.len = 3;  // a heartbeat is exactly 1 byte
    }
    for (auto& b : f.data) b = static_cast<std::uint8_t>(rng());
    send(f);
  }
}

void DriveNode::over_current(Nanos now) {
  (void)now;
  state_ = State::kFault;
  const std::uint8_t error_register = od::error_register::kGeneric | od::error_register::kCurrent;
  set_od(od::kErrorRegister, 0, error_register);
  send(encode_emcy(cfg_.node, 0x2310, error_register));  // output current
}

void DriveNode::handle_sdo(const Frame& f) {
  const std::uint8_t cmd = f.data[0];
  const SdoAddress a{static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8)), f.data[3]};
  const std::uint8_t node = cfg_.node;
  const std::uint32_t abort_cob = kCobSdoTx + node;
  const std::uint8_t ccs = cmd >> 5;
  if (ccs == 3) {  // upload segment request (device name)
    if (upload_.empty()) return send(sdo_abort(abort_cob, {}, abort_code::kCommand));
    if (static_cast<bool>(cmd & 0x10) != upload_toggle_) return send(sdo_abort(abort_cob, {}, abort_code::kToggleBit));
    const std::size_t n = std::min<std::size_t>(7, upload_.size() - upload_off_);
    const bool last = upload_off_ + n >= upload_.size();
    const auto* chunk = reinterpret_cast<const std::uint8_t*>(upload_.data() + upload_off_);
    send(sdo_upload_segment_response(node, upload_toggle_, {chunk, n}, last));
    upload_off_ += n;
    upload_toggle_ = !upload_toggle_;
    if (last) upload_.clear();
    return;
  }
  if (a.index == od::kDeviceName && ccs == 2) {  // segmented upload
    upload_ = cfg_.name;
    upload_off_ = 0;
    upload_toggle_ = false;
    return send(sdo_upload_segmented_init(node, a, static_cast<std::uint32_t>(upload_.size())));
  }
  auto it = od_.find(key(a.index, a.sub));
  if (it == od_.end()) {
    const bool index_exists = std::any_of(od_.begin(), od_.end(), [&](const auto& e) { return (e.first >> 8) == a.index; });
    return send(sdo_abort(abort_cob, a, index_exists ? abort_code::kSubUnknown : abort_code::kNotExist));
  }
  if (ccs == 2) {  // initiate upload
    if (a.index == od::kStatusword) it->second.value = statusword();
    return send(sdo_upload_expedited(node, a, it->second.value, it->second.size));
  }
  if (ccs == 1) {  // initiate download (expedited only)
    if (!(cmd & 0x02)) return send(sdo_abort(abort_cob, a, abort_code::kUnsupportedAccess));
    if (!it->second.writable) return send(sdo_abort(abort_cob, a, abort_code::kReadOnly));
    const std::uint8_t n = (cmd & 0x01) ? static_cast<std::uint8_t>(4 - ((cmd >> 2) & 3)) : 4;
    if (n != it->second.size) return send(sdo_abort(abort_cob, a, abort_code::kTypeMismatch));
    std::uint32_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint32_t>(f.data[4 + i]) << (8 * i);
    if (a.index == od::kModesOfOperation && !supported_mode(v)) return send(sdo_abort(abort_cob, a, abort_code::kInvalidValue));
    it->second.value = v;
    if (a.index == od::kControlword) handle_controlword(static_cast<std::uint16_t>(v));
    if (a.index == od::kModesOfOperation) set_od(od::kModesOfOperationDisplay, 0, v);
    return send(sdo_download_ack(node, a));
  }
  send(sdo_abort(abort_cob, a, abort_code::kCommand));
}

void DriveNode::send_tpdo(unsigned k) {
  const std::uint32_t cob = od(od::tpdo_communication(k), od::kPdoCobId);
  if (cob & od::kPdoDisabled) return;
  Frame f;
  f.id = cob & 0x7FF;
  std::size_t byte = 0;
  const std::uint32_t count = od(od::tpdo_mapping(k), od::kPdoMappingCount);
  for (std::uint32_t i = 1; i <= count && i <= 8; ++i) {
    const std::uint32_t m = od(od::tpdo_mapping(k), static_cast<std::uint8_t>(i));
    const std::uint16_t index = static_cast<std::uint16_t>(m >> 16);
    const std::uint8_t sub = static_cast<std::uint8_t>(m >> 8), bits = static_cast<std::uint8_t>(m);
    std::uint32_t v = index == od::kStatusword ? statusword() : od(index, sub);
    for (std::size_t b = 0; b < bits / 8u && byte < 8; ++b) f.data[byte++] = static_cast<std::uint8_t>(v >> (8 * b));
  }
  f.len = static_cast<std::uint8_t>(byte);
  send(f);
}

void DriveNode::on_frame(const Frame& f, Nanos now) {
  if (silent_ || !booted_ || (f.id & (Frame::kError | Frame::kExtended | Frame::kRemote))) return;
  const Classified c = classify(f.id);
  if (c.kind == Kind::kNmt && f.len == 2 && (f.data[1] == 0 || f.data[1] == cfg_.node)) {
    switch (static_cast<NmtCommand>(f.data[0])) {
      case NmtCommand::kStart: nmt_ = NmtState::kOperational; break;
      case NmtCommand::kStop: nmt_ = NmtState::kStopped; break;
      case NmtCommand::kPreOperational: nmt_ = NmtState::kPreOperational; break;
      case NmtCommand::kResetNode:
      case NmtCommand::kResetComm: power_on(now); break;
    }
    return;
  }
  if (c.kind == Kind::kSdoRequest && c.node == cfg_.node && f.len == 8 && nmt_ != NmtState::kStopped) {
    handle_sdo(f);
    return;
  }
  if (nmt_ != NmtState::kOperational) return;
  if (c.kind == Kind::kSync) {
    ++syncs_;
    last_sync_ = now;
    sync_lost_ = false;
    set_od(od::kPositionActual, 0, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::llround(position_))));
    set_od(od::kVelocityActual, 0, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(velocity_))));
    for (unsigned k = 0; k < std::size(kCobTpdo); ++k) {  // a TPDO this drive lacks reads type 0: not sent
      if (od(od::tpdo_communication(k), od::kPdoTransmissionType) == od::kTransmissionEverySync) send_tpdo(k);
    }
    return;
  }
  if (c.kind == Kind::kRpdo && c.node == cfg_.node && c.pdo == 0) {
    const State before = state_;
    const std::uint32_t target_before = od(od::kTargetVelocity, 0);
    handle_rpdo1(f);
    if (before == State::kOperationEnabled && state_ != State::kOperationEnabled) torque_off_at_ = now;
    if (target_before != 0 && od(od::kTargetVelocity, 0) == 0) zero_target_at_ = now;
  }
}

void DriveNode::handle_rpdo1(const Frame& f) {
  {
    const std::uint32_t cob = od(od::rpdo_communication(0), od::kPdoCobId);
    if (cob & od::kPdoDisabled) return;
    // Unpack by the RPDO1 mapping in this drive's object dictionary (as the master wrote it).
    std::size_t byte = 0;
    const std::uint32_t count = od(od::rpdo_mapping(0), od::kPdoMappingCount);
    for (std::uint32_t i = 1; i <= count && i <= 8; ++i) {
      const std::uint32_t m = od(od::rpdo_mapping(0), static_cast<std::uint8_t>(i));
      const std::uint16_t index = static_cast<std::uint16_t>(m >> 16);
      const std::uint8_t sub = static_cast<std::uint8_t>(m >> 8), bits = static_cast<std::uint8_t>(m);
      if (byte + bits / 8u > f.len) return;  // short frame: ignore it
      std::uint32_t v = 0;
      for (std::size_t b = 0; b < bits / 8u; ++b) v |= static_cast<std::uint32_t>(f.data[byte + b]) << (8 * b);
      byte += bits / 8u;
      set_od(index, sub, v);
      if (index == od::kControlword) handle_controlword(static_cast<std::uint16_t>(v));
    }
  }
}

void DriveNode::update(Nanos now) {
  const double dt = std::max(0.0, nanos_to_seconds(now - last_update_));
  last_update_ = now;
  if (!booted_) {
    if (now >= boot_at_) {
      booted_ = true;
      nmt_ = NmtState::kPreOperational;
      state_ = State::kSwitchOnDisabled;  // automatic transitions 0 and 1
      send(heartbeat(cfg_.node, NmtState::kBootUp));
      next_heartbeat_ = now;
    }
    return;
  }
  // Motor: follow the target within the acceleration limit while enabled; otherwise stop.
  double target = 0, accel = static_cast<double>(od(od::kProfileDeceleration, 0));
  // Sync loss (the master went quiet): stop rather than run on at the last command.
  if (cfg_.sync_loss_s > 0 && nmt_ == NmtState::kOperational && syncs_ > 0 &&
      now - last_sync_ > static_cast<Nanos>(cfg_.sync_loss_s * 1e9)) {
    sync_lost_ = true;
  }
  if (state_ == State::kOperationEnabled && !(last_cw_ & cia402::cw::kHalt) && !sync_lost_) {
    const auto max = static_cast<double>(cfg_.max_velocity);
    target = std::clamp(static_cast<double>(static_cast<std::int32_t>(od(od::kTargetVelocity, 0))), -max, max);
    accel = static_cast<double>(od(od::kProfileAcceleration, 0));
  } else if (state_ == State::kQuickStopActive) {
    accel = static_cast<double>(od(od::kQuickStopDeceleration, 0));
  }
  const double dv = std::clamp(target - velocity_, -accel * dt, accel * dt);
  velocity_ += dv;
  position_ += velocity_ * dt;
  // Heartbeat producer.
  const std::uint32_t hb_ms = od(od::kProducerHeartbeat, 0);
  if (hb_ms > 0 && now >= next_heartbeat_) {
    send(heartbeat(cfg_.node, nmt_));
    next_heartbeat_ = now + static_cast<Nanos>(hb_ms) * kNanosPerMilli;
  }
}

}  // namespace cairn::hil
