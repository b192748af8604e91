#include "hil/lms2xx/lms_device.hpp"

#include "hil/lms2xx/scan_synth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>

namespace cairn::hil {

using namespace cairn::lms;

LmsDevice::LmsDevice(LmsDeviceConfig cfg, const World* world, PoseSource pose)
    : cfg_(std::move(cfg)), world_(world), pose_(std::move(pose)), rng_(cfg_.seed) {}

void LmsDevice::power_on(Nanos now) {
  popped_ += tx_.size();  // discarded, but keep byte indices consistent
  tx_.clear();
  parser_.reset();
  baud_ = cfg_.power_on_baud;
  pending_baud_ = 0;
  booted_ = false;
  boot_done_ = now + seconds_to_nanos(cfg_.boot_time_s);
  installation_ = false;
  streaming_ = false;
  angle_ = 180;
  res_ = 100;
  config_ = ConfigBlock{};  // factory default: cm, measuring mode 0
  ++counters_.power_ons;
}

void LmsDevice::queue(const Frame& f) {
  std::size_t start = tx_.size();
  tx_.insert(tx_.end(), f.bytes.begin(), f.bytes.begin() + static_cast<long>(f.size));
  if (corrupt_crc_) {
    tx_.back() ^= 0x5A;
    corrupt_crc_ = false;
  }
  if (drop_bytes_ > 0 && f.size > drop_bytes_ + 8) {
    const auto mid = tx_.begin() + static_cast<long>(start + f.size / 2);
    tx_.erase(mid, mid + static_cast<long>(drop_bytes_));
    drop_bytes_ = 0;
  }
}

void LmsDevice::reply(std::uint8_t code, std::span<const std::uint8_t> data, std::uint8_t status) {
  std::uint8_t buf[kMaxPayload];
  std::copy(data.begin(), data.end(), buf);
  buf[data.size()] = status;
  Frame f;
  encode(kReplyAddress, code, {buf, data.size() + 1}, &f);
  queue(f);
}

void LmsDevice::receive(std::span<const std::uint8_t> bytes, Nanos now) {
  if (!booted_) return;  // still booting: deaf
  while (!bytes.empty()) {
    std::size_t used = 0;
    const auto before = parser_.counters().crc_errors;
    const auto ev = parser_.feed(bytes, &used);
    if (parser_.counters().crc_errors != before) {
      tx_.push_back(kNak);
      ++counters_.naks_sent;
    }
    if (ev == Parser::Event::kTelegram) handle(parser_.telegram(), now);
    bytes = bytes.subspan(used);
  }
}

void LmsDevice::handle(const Telegram& t, Nanos now) {
  ++counters_.requests;
  tx_.push_back(kAck);
  switch (t.command) {
    case kCmdMode: {
      if (t.data.empty()) {
        const std::uint8_t r[] = {0x01};
        reply(kReplyMode, r);
        return;
      }
      const std::uint8_t mode = t.data[0];
      std::uint8_t result = 0x00;
      if (mode == kModeInstallation) {
        std::string pw(t.data.begin() + 1, t.data.end());
        installation_ = pw == cfg_.password;
        result = installation_ ? 0x00 : 0x01;
      } else if (mode == kModeStreamAll) {
        streaming_ = true;
        installation_ = false;
        next_scan_ = now;
      } else if (mode == kModeOnRequest) {
        streaming_ = false;
        installation_ = false;
      } else if (const std::uint32_t b = baud_of_code(mode)) {
        const std::uint8_t r[] = {0x00};
        reply(kReplyMode, r, 0x10);  // at the old rate; switch once it is on the wire
        pending_baud_ = b;
        return;
      } else {
        result = 0x01;  // a mode this emulator does not offer
      }
      const std::uint8_t r[] = {result};
      reply(kReplyMode, r);
      return;
    }
    case kCmdVariant: {
      bool ok = t.data.size() == 4;
      std::uint16_t angle = 0, res = 0;
      if (ok) {
        angle = static_cast<std::uint16_t>(t.data[0] | (t.data[1] << 8));
        res = static_cast<std::uint16_t>(t.data[2] | (t.data[3] << 8));
        ok = valid_variant(angle, res);
      }
      if (ok) {
        angle_ = angle;
        res_ = res;
      }
      const std::uint8_t r[] = {static_cast<std::uint8_t>(ok ? 1 : 0), static_cast<std::uint8_t>(angle_ & 0xFF),
                                static_cast<std::uint8_t>(angle_ >> 8), static_cast<std::uint8_t>(res_ & 0xFF),
                                static_cast<std::uint8_t>(res_ >> 8)};
      reply(kReplyVariant, r);
      return;
    }
    case kCmdStatus: {
      StatusReply s;
      std::copy_n("V02.30 ", 7, s.version.begin());
      s.operating_mode = streaming_ ? kModeStreamAll : (installation_ ? kModeInstallation : kModeOnRequest);
      s.measuring_mode = config_.measuring_mode();
      s.units = config_.units();
      s.scan_angle = angle_;
      s.resolution = res_;
      std::array<std::uint8_t, 153> data;
      encode_status_data(s, &data);
      Frame f;
      encode(kReplyAddress, kReplyStatus, data, &f);
      queue(f);
      return;
    }
    case kCmdType: {
      std::string s = cfg_.type;
      s.resize(20, ' ');
      reply(kReplyType, {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()});
      return;
    }
    case kCmdReadConfig:
      reply(kReplyConfig, config_.bytes);
      return;
    case kCmdWriteConfig: {
      std::uint8_t r[33] = {0};
      if (installation_ && (t.data.size() == 32 || t.data.size() == 34)) {
        std::copy_n(t.data.begin(), 32, config_.bytes.begin());
        r[0] = 0x01;
      }
      std::copy(config_.bytes.begin(), config_.bytes.end(), r + 1);
      reply(kReplyWriteConfig, r);
      return;
    }
    case kCmdReset:
      reply(kReplyReset, {});
      power_on(now);
      return;
    case kCmdRequestValues:
      queue_scan(now);
      return;
    default: {
      ++counters_.unknown_commands;
      reply(kReplyNack, {});
      return;
    }
  }
}

void LmsDevice::on_tx_drained(Nanos now) {
  (void)now;
  if (pending_baud_) {
    baud_ = pending_baud_;
    pending_baud_ = 0;
    ++counters_.baud_changes;
  }
}

std::uint16_t LmsDevice::encode_range(double range_m, bool hit, bool reflective) const {
  const int bits = range_bits(config_.measuring_mode());
  const std::uint32_t field_max = bits >= 16 ? 0xFFFF : ((1u << bits) - 1);
  const double per_unit = config_.units() == 1 ? 0.001 : (config_.units() == 2 ? 0.1 : 0.01);
  std::uint32_t v = field_max;  // no echo: the top of the range field
  if (hit) v = std::min<std::uint32_t>(field_max - 1, static_cast<std::uint32_t>(std::lround(std::max(0.0, range_m) / per_unit)));
  // Reflector bits sit above the range field in the reflector modes (0x01, 0x03, 0x05).
  const std::uint8_t mm = config_.measuring_mode();
  if (reflective && hit && (mm == 0x01 || mm == 0x03 || mm == 0x05)) v |= 1u << bits;
  return static_cast<std::uint16_t>(v);
}

void LmsDevice::queue_scan(Nanos now) {
  const int n = sweep_beams(angle_, res_);
  const Pose2 sensor = pose_(now);
  const std::uint16_t partial = cfg_.interlaced ? partial_ : 0;
  partial_ = static_cast<std::uint8_t>((partial_ + 1) % 4);
  Pose2 sweep = sensor;  // an interlaced partial scan starts index x 0.25 deg further round
  sweep.theta += partial * 0.25 * std::numbers::pi / 180.0;
  std::array<BeamSample, kMaxBeams> beams;
  synthesize_sweep(*world_, sweep, angle_, res_, cfg_.max_range_m, cfg_.range_noise_m, rng_, beams.data());
  std::uint8_t data[2 + 2 * kMaxBeams];
  const std::uint16_t units = config_.units() & 0x3;
  const std::uint16_t word = static_cast<std::uint16_t>(n | (partial << 11) | (units << 14));
  data[0] = static_cast<std::uint8_t>(word & 0xFF);
  data[1] = static_cast<std::uint8_t>(word >> 8);
  // The host's view of each value, for the scan's fingerprint (no allocation: fixed arrays).
  const int bits = range_bits(config_.measuring_mode());
  const std::uint32_t field_max = bits >= 16 ? 0xFFFF : ((1u << bits) - 1);
  const std::uint32_t unit_mm = config_.units() == 1 ? 1 : (config_.units() == 2 ? 100 : 10);
  std::array<std::uint16_t, kMaxBeams> host_mm{};
  std::array<std::uint8_t, kMaxBeams> host_flags{};
  for (int i = 0; i < n; ++i) {
    const BeamSample& b = beams[static_cast<std::size_t>(i)];
    const std::uint16_t v = encode_range(b.range_m, b.hit, b.reflective);
    data[2 + 2 * i] = static_cast<std::uint8_t>(v & 0xFF);
    data[3 + 2 * i] = static_cast<std::uint8_t>(v >> 8);
    const std::uint32_t field = v & field_max;
    host_mm[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(field == field_max ? 0 : std::min<std::uint32_t>(field * unit_mm, 0xFFFF));
    host_flags[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(bits >= 16 ? 0 : (v >> bits));
  }
  std::uint8_t payload[2 + 2 * kMaxBeams + 1];
  std::memcpy(payload, data, static_cast<std::size_t>(2 + 2 * n));
  payload[2 + 2 * n] = 0x00;  // status
  Frame f;
  encode(kReplyAddress, kReplyValues, {payload, static_cast<std::size_t>(3 + 2 * n)}, &f);
  SentScan s;
  s.index = ++scan_index_;
  s.sweep_start = now - static_cast<Nanos>(angle_ / 360.0 / 75.0 * 1e9);  // the sweep ended now
  s.bytes = f.size;
  s.sensor_pose = sensor;
  s.first_byte = popped_ + tx_.size();
  s.fingerprint = scan_fingerprint(static_cast<std::size_t>(n), host_mm.data(), host_flags.data());
  sent_.push_back(s);
  if (sent_.size() > 1000) sent_.pop_front();
  queue(f);
  ++counters_.scans_sent;
}

void LmsDevice::poll(Nanos now, bool line_idle) {
  if (!booted_ && now >= boot_done_) {
    booted_ = true;
    std::string t = "LMS291;S05 power on";
    t.resize(24, ' ');
    reply(kReplyPowerOn, {reinterpret_cast<const std::uint8_t*>(t.data()), t.size()});
  }
  if (!booted_ || !streaming_) return;
  const int rotations = res_ == 100 ? 1 : (res_ == 50 ? 2 : 4);
  const Nanos period = rotations * kNanosPerSecond / 75;
  if (now < next_scan_) return;
  while (next_scan_ + period <= now) next_scan_ += period;  // catch up (missed sweeps are lost)
  next_scan_ += period;
  if (!line_idle || !tx_.empty()) {
    ++counters_.scans_dropped_busy;
    return;
  }
  queue_scan(now);
}

void LmsDevice::inject_garbage(std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) tx_.push_back(static_cast<std::uint8_t>(rng_()));
}
void LmsDevice::corrupt_next_telegram_crc() { corrupt_crc_ = true; }
void LmsDevice::drop_from_next_telegram(std::size_t n) { drop_bytes_ = n; }
void LmsDevice::force_baud(std::uint32_t baud) { baud_ = baud; }

}  // namespace cairn::hil
