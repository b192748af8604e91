#include "hil/cia402/drive_node.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::hil {

using namespace cairn::canopen;
using cia402::State;

namespace {
constexpr std::uint32_t key(std::uint16_t index, std::uint8_t sub) { return (static_cast<std::uint32_t>(index) << 8) | sub; }
}  // namespace

DriveNode::DriveNode(DriveConfig cfg) : cfg_(std::move(cfg)) { reset_communication(); }

void DriveNode::reset_communication() {
  const std::uint8_t n = cfg_.node;
  od_.clear();
  auto def = [&](std::uint16_t i, std::uint8_t s, std::uint32_t v, std::uint8_t size, bool w) { od_[key(i, s)] = {v, size, w}; };
  def(0x1000, 0, 0xFFFF0192, 4, false);  // device type: CiA 402
  def(0x1001, 0, 0, 1, false);           // error register
  def(0x1017, 0, 0, 2, true);            // producer heartbeat time (ms)
  // RPDO1: controlword + target velocity
  def(0x1400, 1, 0x200u + n, 4, true);
  def(0x1400, 2, 255, 1, true);
  def(0x1600, 0, 2, 1, true);
  def(0x1600, 1, mapping_entry(0x6040, 0, 16), 4, true);
  def(0x1600, 2, mapping_entry(0x60FF, 0, 32), 4, true);
  // TPDO1: statusword + velocity actual; TPDO2: position actual
  def(0x1800, 1, 0x180u + n, 4, true);
  def(0x1800, 2, 1, 1, true);
  def(0x1A00, 0, 2, 1, true);
  def(0x1A00, 1, mapping_entry(0x6041, 0, 16), 4, true);
  def(0x1A00, 2, mapping_entry(0x606C, 0, 32), 4, true);
  def(0x1801, 1, 0x280u + n, 4, true);
  def(0x1801, 2, 1, 1, true);
  def(0x1A01, 0, 1, 1, true);
  def(0x1A01, 1, mapping_entry(0x6064, 0, 32), 4, true);
  // CiA 402
  def(0x6040, 0, 0, 2, true);        // controlword
  def(0x6041, 0, 0, 2, false);       // statusword
  def(0x6060, 0, 0, 1, true);        // modes of operation
  def(0x6061, 0, 0, 1, false);       // modes of operation display
  def(0x6064, 0, 0, 4, false);       // position actual
  def(0x606C, 0, 0, 4, false);       // velocity actual
  def(0x6083, 0, 400000, 4, true);   // profile acceleration (increments/s²)
  def(0x6084, 0, 400000, 4, true);   // profile deceleration
  def(0x6085, 0, 2000000, 4, true);  // quick stop deceleration
  def(0x60FF, 0, 0, 4, true);        // target velocity
  def(0x6502, 0, 0x0104, 4, false);  // supported modes: pv, csv
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
  if (std::abs(velocity_ - static_cast<double>(static_cast<std::int32_t>(od(0x60FF, 0)))) < 100) sw |= 0x0400;  // target reached
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
      set_od(0x1001, 0, 0);
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
  const std::uint32_t own[] = {0x180u + cfg_.node, 0x280u + cfg_.node, 0x700u + cfg_.node, 0x080u + cfg_.node, 0x580u + cfg_.node};
  for (std::size_t i = 0; i < n; ++i) {
    Frame f;
    if (i % 2) {
      f.id = 0x7E0 + static_cast<std::uint32_t>(rng() % 0x1F);  // foreign traffic outside CANopen's node range
      f.len = static_cast<std::uint8_t>(rng() % 9);
    } else {
      f.id = own[rng() % 5];
      f.len = static_cast<std::uint8_t>(1 + rng() % 3);  // too short for any of them (SDO 8, EMCY 8, TPDO 4/6)
      if (f.id == 0x700u + cfg_.node) f.len = 3;         // a heartbeat is exactly 1 byte
    }
    for (auto& b : f.data) b = static_cast<std::uint8_t>(rng());
    send(f);
  }
}

void DriveNode::over_current(Nanos now) {
  (void)now;
  state_ = State::kFault;
  set_od(0x1001, 0, 0x03);  // generic + current
  send(encode_emcy(cfg_.node, 0x2310, 0x03));
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
  if (a.index == 0x1008 && ccs == 2) {  // device name: segmented upload
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
    if (a.index == 0x6041) it->second.value = statusword();
    return send(sdo_upload_expedited(node, a, it->second.value, it->second.size));
  }
  if (ccs == 1) {  // initiate download (expedited only)
    if (!(cmd & 0x02)) return send(sdo_abort(abort_cob, a, abort_code::kUnsupportedAccess));
    if (!it->second.writable) return send(sdo_abort(abort_cob, a, abort_code::kReadOnly));
    const std::uint8_t n = (cmd & 0x01) ? static_cast<std::uint8_t>(4 - ((cmd >> 2) & 3)) : 4;
    if (n != it->second.size) return send(sdo_abort(abort_cob, a, abort_code::kTypeMismatch));
    std::uint32_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint32_t>(f.data[4 + i]) << (8 * i);
    if (a.index == 0x6060 && v != 3 && v != 9 && v != 0) return send(sdo_abort(abort_cob, a, abort_code::kInvalidValue));
    it->second.value = v;
    if (a.index == 0x6040) handle_controlword(static_cast<std::uint16_t>(v));
    if (a.index == 0x6060) set_od(0x6061, 0, v);
    return send(sdo_download_ack(node, a));
  }
  send(sdo_abort(abort_cob, a, abort_code::kCommand));
}

void DriveNode::send_tpdo(int k) {
  const std::uint32_t cob = od(static_cast<std::uint16_t>(0x1800 + k), 1);
  if (cob & 0x80000000u) return;  // disabled
  Frame f;
  f.id = cob & 0x7FF;
  std::size_t byte = 0;
  const std::uint32_t count = od(static_cast<std::uint16_t>(0x1A00 + k), 0);
  for (std::uint32_t i = 1; i <= count && i <= 8; ++i) {
    const std::uint32_t m = od(static_cast<std::uint16_t>(0x1A00 + k), static_cast<std::uint8_t>(i));
    const std::uint16_t index = static_cast<std::uint16_t>(m >> 16);
    const std::uint8_t sub = static_cast<std::uint8_t>(m >> 8), bits = static_cast<std::uint8_t>(m);
    std::uint32_t v = index == 0x6041 ? statusword() : od(index, sub);
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
    set_od(0x6064, 0, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::llround(position_))));
    set_od(0x606C, 0, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(velocity_))));
    for (int k = 0; k < 2; ++k) {
      if (od(static_cast<std::uint16_t>(0x1800 + k), 2) == 1) send_tpdo(k);
    }
    return;
  }
  if (c.kind == Kind::kRpdo && c.node == cfg_.node && c.pdo == 0) {
    const State before = state_;
    const std::uint32_t target_before = od(0x60FF, 0);
    handle_rpdo1(f);
    if (before == State::kOperationEnabled && state_ != State::kOperationEnabled) torque_off_at_ = now;
    if (target_before != 0 && od(0x60FF, 0) == 0) zero_target_at_ = now;
  }
}

void DriveNode::handle_rpdo1(const Frame& f) {
  {
    const std::uint32_t cob = od(0x1400, 1);
    if (cob & 0x80000000u) return;
    // Unpack by the RPDO1 mapping.
    std::size_t byte = 0;
    const std::uint32_t count = od(0x1600, 0);
    for (std::uint32_t i = 1; i <= count && i <= 8; ++i) {
      const std::uint32_t m = od(0x1600, static_cast<std::uint8_t>(i));
      const std::uint16_t index = static_cast<std::uint16_t>(m >> 16);
      const std::uint8_t sub = static_cast<std::uint8_t>(m >> 8), bits = static_cast<std::uint8_t>(m);
      if (byte + bits / 8u > f.len) return;  // short frame: ignore it
      std::uint32_t v = 0;
      for (std::size_t b = 0; b < bits / 8u; ++b) v |= static_cast<std::uint32_t>(f.data[byte + b]) << (8 * b);
      byte += bits / 8u;
      set_od(index, sub, v);
      if (index == 0x6040) handle_controlword(static_cast<std::uint16_t>(v));
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
  double target = 0, accel = static_cast<double>(od(0x6084, 0));
  // Sync loss (the master went quiet): stop rather than run on at the last command.
  if (cfg_.sync_loss_s > 0 && nmt_ == NmtState::kOperational && syncs_ > 0 &&
      now - last_sync_ > static_cast<Nanos>(cfg_.sync_loss_s * 1e9)) {
    sync_lost_ = true;
  }
  if (state_ == State::kOperationEnabled && !(last_cw_ & cia402::cw::kHalt) && !sync_lost_) {
    target = std::clamp(static_cast<double>(static_cast<std::int32_t>(od(0x60FF, 0))), -static_cast<double>(cfg_.max_velocity),
                        static_cast<double>(cfg_.max_velocity));
    accel = static_cast<double>(od(0x6083, 0));
  } else if (state_ == State::kQuickStopActive) {
    accel = static_cast<double>(od(0x6085, 0));
  }
  const double dv = std::clamp(target - velocity_, -accel * dt, accel * dt);
  velocity_ += dv;
  position_ += velocity_ * dt;
  // Heartbeat producer.
  const std::uint32_t hb_ms = od(0x1017, 0);
  if (hb_ms > 0 && now >= next_heartbeat_) {
    send(heartbeat(cfg_.node, nmt_));
    next_heartbeat_ = now + static_cast<Nanos>(hb_ms) * kNanosPerMilli;
  }
}

}  // namespace cairn::hil
