#include "drivers/sick/lms_codec.hpp"

#include <algorithm>
#include <cstring>

namespace cairn::lms {

std::uint16_t crc16(std::span<const std::uint8_t> bytes) {
  std::uint16_t crc = 0;
  std::uint8_t prev = 0;
  for (std::uint8_t b : bytes) {
    if (crc & 0x8000) {
      crc = static_cast<std::uint16_t>((crc << 1) ^ 0x8005);
    } else {
      crc = static_cast<std::uint16_t>(crc << 1);
    }
    crc ^= static_cast<std::uint16_t>((prev << 8) | b);
    prev = b;
  }
  return crc;
}

std::optional<std::uint8_t> baud_code(std::uint32_t baud) {
  switch (baud) {
    case 9600: return kBaud9600;
    case 19200: return kBaud19200;
    case 38400: return kBaud38400;
    case 500000: return kBaud500000;
    default: return std::nullopt;
  }
}

std::uint32_t baud_of_code(std::uint8_t code) {
  switch (code) {
    case kBaud9600: return 9600;
    case kBaud19200: return 19200;
    case kBaud38400: return 38400;
    case kBaud500000: return 500000;
    default: return 0;
  }
}

bool encode(std::uint8_t address, std::uint8_t command, std::span<const std::uint8_t> data, Frame* out) {
  const std::size_t len = 1 + data.size();
  if (len > kMaxPayload) return false;
  auto& b = out->bytes;
  b[0] = kStx;
  b[1] = address;
  b[2] = static_cast<std::uint8_t>(len & 0xFF);
  b[3] = static_cast<std::uint8_t>(len >> 8);
  b[4] = command;
  std::copy(data.begin(), data.end(), b.begin() + 5);
  const std::size_t body = 4 + len;
  const std::uint16_t crc = crc16({b.data(), body});
  b[body] = static_cast<std::uint8_t>(crc & 0xFF);
  b[body + 1] = static_cast<std::uint8_t>(crc >> 8);
  out->size = body + 2;
  return true;
}

namespace {
Frame make(std::uint8_t command, std::span<const std::uint8_t> data) {
  Frame f;
  encode(kHostAddress, command, data, &f);
  return f;
}
}  // namespace

Frame request_mode(std::uint8_t mode) {
  const std::uint8_t d[] = {mode};
  return make(kCmdMode, d);
}

Frame request_installation_mode(std::string_view password) {
  std::uint8_t d[9] = {kModeInstallation};
  for (std::size_t i = 0; i < 8; ++i) d[1 + i] = i < password.size() ? static_cast<std::uint8_t>(password[i]) : ' ';
  return make(kCmdMode, d);
}

Frame request_status() { return make(kCmdStatus, {}); }
Frame request_type() { return make(kCmdType, {}); }
Frame request_read_config() { return make(kCmdReadConfig, {}); }
Frame request_reset() { return make(kCmdReset, {}); }

Frame request_values() {
  const std::uint8_t d[] = {0x01};
  return make(kCmdRequestValues, d);
}

Frame request_variant(std::uint16_t angle_deg, std::uint16_t res_centideg) {
  const std::uint8_t d[] = {static_cast<std::uint8_t>(angle_deg & 0xFF), static_cast<std::uint8_t>(angle_deg >> 8),
                            static_cast<std::uint8_t>(res_centideg & 0xFF), static_cast<std::uint8_t>(res_centideg >> 8)};
  return make(kCmdVariant, d);
}

Frame request_write_config(std::span<const std::uint8_t, 32> block) { return make(kCmdWriteConfig, block); }

ConfigBlock ConfigBlock::millimetres() {
  ConfigBlock c;
  c.bytes[6] = 1;   // units: mm
  c.bytes[9] = 2;   // multiple evaluation
  c.bytes[10] = 2;  // restart
  return c;
}

int range_bits(std::uint8_t measuring_mode) {
  switch (measuring_mode) {
    case 0x03:
    case 0x04: return 14;
    case 0x05:
    case 0x06: return 15;
    case 0x0F: return 16;
    default: return 13;
  }
}

bool decode_values(const Telegram& t, std::uint8_t measuring_mode, ScanValues* out) {
  if (t.command != kReplyValues || t.data.size() < 3) return false;
  const std::uint16_t word = static_cast<std::uint16_t>(t.data[0] | (t.data[1] << 8));
  const std::uint16_t n = word & 0x03FF;
  if (n > kMaxBeams) return false;
  const std::size_t need = 2 + 2 * static_cast<std::size_t>(n) + 1;
  // Optional real-time scan index byte before STATUS (availability flag 0x02).
  if (t.data.size() != need && t.data.size() != need + 1) return false;
  out->count = n;
  out->partial_index = static_cast<std::uint8_t>((word >> 11) & 0x3);
  const int unit_bits = (word >> 14) & 0x3;
  if (unit_bits == 3) return false;
  out->units = static_cast<Units>(unit_bits);
  const int bits = range_bits(measuring_mode);
  const std::uint32_t mask = bits >= 16 ? 0xFFFFu : ((1u << bits) - 1);
  const std::uint32_t scale = out->units == Units::kMillimetres ? 1 : (out->units == Units::kCentimetres ? 10 : 100);
  out->saturated = 0;
  for (std::uint16_t i = 0; i < n; ++i) {
    const std::uint16_t v = static_cast<std::uint16_t>(t.data[2 + 2 * i] | (t.data[3 + 2 * i] << 8));
    std::uint32_t mm = (v & mask) * scale;
    if (mm > 0xFFFF) {
      mm = 0xFFFF;
      ++out->saturated;
    }
    out->range_mm[i] = static_cast<std::uint16_t>(mm);
    out->flags[i] = static_cast<std::uint8_t>(bits >= 16 ? 0 : (v >> bits));
  }
  out->status = t.data.back();
  return true;
}

bool decode_variant(const Telegram& t, VariantReply* out) {
  if (t.command != kReplyVariant || t.data.size() < 6) return false;
  out->accepted = t.data[0] == 0x01;
  out->angle_deg = static_cast<std::uint16_t>(t.data[1] | (t.data[2] << 8));
  out->res_centideg = static_cast<std::uint16_t>(t.data[3] | (t.data[4] << 8));
  return true;
}

// Offsets are sicktoolbox's payload offsets (payload[0] = 0xB1) minus one.
bool decode_status(const Telegram& t, StatusReply* out) {
  if (t.command != kReplyStatus || t.data.size() < 123) return false;
  const auto& d = t.data;
  for (std::size_t i = 0; i < 7; ++i) out->version[i] = static_cast<char>(d[i]);
  out->version[7] = '\0';
  out->operating_mode = d[7];
  out->device_status = d[8];
  out->measuring_mode = d[101];
  out->scan_angle = static_cast<std::uint16_t>(d[106] | (d[107] << 8));
  out->resolution = static_cast<std::uint16_t>(d[108] | (d[109] << 8));
  out->units = d[121];
  return true;
}

void encode_status_data(const StatusReply& s, std::array<std::uint8_t, 153>* data) {
  data->fill(0);
  auto& d = *data;
  for (std::size_t i = 0; i < 7; ++i) d[i] = static_cast<std::uint8_t>(s.version[i]);
  d[7] = s.operating_mode;
  d[8] = s.device_status;
  d[101] = s.measuring_mode;
  d[106] = static_cast<std::uint8_t>(s.scan_angle & 0xFF);
  d[107] = static_cast<std::uint8_t>(s.scan_angle >> 8);
  d[108] = static_cast<std::uint8_t>(s.resolution & 0xFF);
  d[109] = static_cast<std::uint8_t>(s.resolution >> 8);
  d[121] = s.units;
  d[152] = 0x10;  // status byte
}

// ---------------------------------------------------------------- parser

// Keeps the buffer starting at the next plausible telegram start after index 0.
static std::size_t next_start(const std::uint8_t* buf, std::size_t have, std::uint8_t address) {
  for (std::size_t i = 1; i < have; ++i) {
    if (buf[i] == kStx && (i + 1 == have || buf[i + 1] == address)) return i;
  }
  return have;
}

// Drops the buffer's first byte and everything up to the next plausible telegram start.
void Parser::resync() {
  const std::size_t s = next_start(buf_.data(), have_, address_);
  counters_.skipped_bytes += s;
  ++counters_.resyncs;
  std::memmove(buf_.data(), buf_.data() + s, have_ - s);
  have_ -= s;
}

bool Parser::try_complete() {
  if (have_ < 4) return false;
  const std::size_t len = static_cast<std::size_t>(buf_[2] | (buf_[3] << 8));
  if (len == 0 || len > kMaxPayload) {
    ++counters_.bad_length;
    resync();
    return false;
  }
  if (have_ < len + 6) return false;
  const std::uint16_t crc = static_cast<std::uint16_t>(buf_[len + 4] | (buf_[len + 5] << 8));
  if (crc != crc16({buf_.data(), len + 4})) {
    ++counters_.crc_errors;
    resync();
    return false;
  }
  telegram_.address = buf_[1];
  telegram_.length = static_cast<std::uint16_t>(len);
  telegram_.command = buf_[4];
  telegram_.data = {buf_.data() + 5, len - 1};
  return true;
}

Parser::Event Parser::feed(std::span<const std::uint8_t> bytes, std::size_t* consumed) {
  // A telegram handed out by the previous call is dropped now.
  if (delivered_) {
    delivered_ = false;
    have_ = 0;
    telegram_ = {};
  }
  std::size_t i = 0;
  while (i < bytes.size()) {
    const std::uint8_t b = bytes[i++];
    if (have_ == 0) {
      if (b == kStx) {
        buf_[0] = b;
        have_ = 1;
        skipping_ = false;
        continue;
      }
      if (!skipping_ && (b == kAck || b == kNak)) {
        *consumed = i;
        if (b == kAck) {
          ++counters_.acks;
          return Event::kAckByte;
        }
        ++counters_.naks;
        return Event::kNakByte;
      }
      if (!skipping_) {
        ++counters_.resyncs;
        skipping_ = true;
      }
      ++counters_.skipped_bytes;
      continue;
    }
    if (have_ == 1 && b != address_) {
      // STX not followed by our address: not a telegram start.
      if (!skipping_) {
        ++counters_.resyncs;
        skipping_ = true;
      }
      ++counters_.skipped_bytes;  // the STX
      if (b == kStx) continue;    // this one may be the start
      have_ = 0;
      ++counters_.skipped_bytes;
      continue;
    }
    buf_[have_++] = b;
    // Complete, or resynchronised into a shorter buffer that may itself complete.
    while (have_ >= 4) {
      const std::size_t before = have_;
      if (try_complete()) {
        ++counters_.telegrams;
        delivered_ = true;
        *consumed = i;
        return Event::kTelegram;
      }
      if (have_ == before) break;
      if (have_ == 1 && buf_[0] != kStx) have_ = 0;
    }
    if (have_ == 1 && buf_[0] != kStx) have_ = 0;
  }
  *consumed = i;
  return Event::kNone;
}

}  // namespace cairn::lms
