#include "drivers/canopen/canopen_codec.hpp"

#include <algorithm>
#include <cstring>

namespace cairn::canopen {

const char* nmt_state_name(NmtState s) {
  switch (s) {
    case NmtState::kBootUp: return "boot-up";
    case NmtState::kStopped: return "stopped";
    case NmtState::kOperational: return "operational";
    case NmtState::kPreOperational: return "pre-operational";
  }
  return "unknown";
}

namespace {
Frame make(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (std::uint8_t b : bytes) f.data[i++] = b;
  return f;
}
void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint16_t get16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) | (static_cast<std::uint32_t>(p[2]) << 16) |
         (static_cast<std::uint32_t>(p[3]) << 24);
}
bool standard(const Frame& f) { return is_standard_data_frame(f); }
// An SDO response frame (server -> client): command byte, index, sub, 4 data bytes.
Frame sdo_response(std::uint8_t node, std::uint8_t command, SdoAddress a, std::uint32_t data) {
  Frame f;
  f.id = kCobSdoTx + node;
  f.len = 8;
  f.data[0] = command;
  put16(f.data.data() + 1, a.index);
  f.data[3] = a.sub;
  put32(f.data.data() + 4, data);
  return f;
}
// The command byte of a segment, either direction (the command specifier is 0 for both a
// download segment request and an upload segment response): toggle in bit 4, the number
// of unused bytes in bits 3..1, no more segments in bit 0.
std::uint8_t segment_command(bool toggle, std::size_t n, bool last) {
  return static_cast<std::uint8_t>((toggle ? 0x10 : 0) | ((7 - n) << 1) | (last ? 1 : 0));
}
}  // namespace

Frame nmt(NmtCommand cmd, std::uint8_t node) { return make(kCobNmt, {static_cast<std::uint8_t>(cmd), node}); }

Frame sync(std::optional<std::uint8_t> counter) {
  if (counter) return make(kCobSync, {*counter});
  return make(kCobSync, {});
}

Frame heartbeat(std::uint8_t node, NmtState state) { return make(kCobHeartbeat + node, {static_cast<std::uint8_t>(state)}); }

Classified classify(std::uint32_t cob_id) {
  const std::uint32_t id = cob_id & 0x7FF;
  const std::uint8_t node = static_cast<std::uint8_t>(id & 0x7F);
  const std::uint32_t fn = id & 0x780;
  if (id == kCobNmt) return {Kind::kNmt, 0, 0};
  if (id == kCobSync) return {Kind::kSync, 0, 0};
  if (node == 0) return {Kind::kOther, 0, 0};
  switch (fn) {
    case 0x080: return {Kind::kEmcy, node, 0};
    case 0x180: return {Kind::kTpdo, node, 0};
    case 0x280: return {Kind::kTpdo, node, 1};
    case 0x380: return {Kind::kTpdo, node, 2};
    case 0x480: return {Kind::kTpdo, node, 3};
    case 0x200: return {Kind::kRpdo, node, 0};
    case 0x300: return {Kind::kRpdo, node, 1};
    case 0x400: return {Kind::kRpdo, node, 2};
    case 0x500: return {Kind::kRpdo, node, 3};
    case 0x580: return {Kind::kSdoResponse, node, 0};
    case 0x600: return {Kind::kSdoRequest, node, 0};
    case 0x700: return {Kind::kHeartbeat, node, 0};
    default: return {Kind::kOther, node, 0};
  }
}

std::optional<Heartbeat> decode_heartbeat(const Frame& f) {
  const Classified c = classify(f.id);
  if (!standard(f) || c.kind != Kind::kHeartbeat || f.len != 1) return std::nullopt;
  const std::uint8_t s = f.data[0] & 0x7F;  // bit 7 is the (legacy) toggle
  if (s != 0x00 && s != 0x04 && s != 0x05 && s != 0x7F) return std::nullopt;
  return Heartbeat{c.node, static_cast<NmtState>(s)};
}

std::optional<Emcy> decode_emcy(const Frame& f) {
  const Classified c = classify(f.id);
  if (!standard(f) || c.kind != Kind::kEmcy || f.len != 8) return std::nullopt;
  Emcy e;
  e.node = c.node;
  e.code = get16(f.data.data());
  e.error_register = f.data[2];
  std::memcpy(e.vendor.data(), f.data.data() + 3, 5);
  return e;
}

Frame encode_emcy(std::uint8_t node, std::uint16_t code, std::uint8_t error_register) {
  Frame f;
  f.id = kCobEmcy + node;
  f.len = 8;
  put16(f.data.data(), code);
  f.data[2] = error_register;
  return f;
}

const char* emcy_text(std::uint16_t code) {
  if (code == 0x0000) return "error reset / no error";
  switch (code >> 12) {
    case 0x1: return "generic error";
    case 0x2: return (code & 0xFF00) == 0x2300 ? "output current (over-current)" : "current";
    case 0x3: return "voltage";
    case 0x4: return "temperature";
    case 0x5: return "device hardware";
    case 0x6: return "device software";
    case 0x7: return "additional modules";
    case 0x8: return (code & 0xFF00) == 0x8100 ? "communication (heartbeat, overrun, bus-off)" : "monitoring";
    case 0x9: return "external error";
    case 0xF: return "additional functions";
    case 0xFF: return "device specific";
    default: return "device specific";
  }
}

const std::array<AbortCodeText, 28> kAbortCodeTexts = {{
    {abort_code::kToggleBit, "toggle bit not altered"},
    {abort_code::kTimeout, "SDO protocol timed out"},
    {abort_code::kCommand, "command specifier not valid or unknown"},
    {abort_code::kOutOfMemory, "out of memory"},
    {abort_code::kUnsupportedAccess, "unsupported access to an object"},
    {abort_code::kWriteOnly, "attempt to read a write-only object"},
    {abort_code::kReadOnly, "attempt to write a read-only object"},
    {abort_code::kNotExist, "object does not exist in the object dictionary"},
    {abort_code::kNoMap, "object cannot be mapped to the PDO"},
    {abort_code::kMapLength, "the number and length of the objects to be mapped would exceed PDO length"},
    {abort_code::kParameterIncompatible, "general parameter incompatibility"},
    {abort_code::kDeviceIncompatible, "general internal incompatibility in the device"},
    {abort_code::kHardware, "access failed due to a hardware error"},
    {abort_code::kTypeMismatch, "data type does not match, length of service parameter does not match"},
    {abort_code::kDataTooLong, "data type does not match, length of service parameter too high"},
    {abort_code::kDataTooShort, "data type does not match, length of service parameter too low"},
    {abort_code::kSubUnknown, "sub-index does not exist"},
    {abort_code::kInvalidValue, "invalid value for parameter"},
    {abort_code::kValueTooHigh, "value of parameter written too high"},
    {abort_code::kValueTooLow, "value of parameter written too low"},
    {abort_code::kMaxLessThanMin, "maximum value is less than minimum value"},
    {abort_code::kNoResource, "resource not available: SDO connection"},
    {abort_code::kGeneral, "general error"},
    {abort_code::kDataTransfer, "data cannot be transferred or stored to the application"},
    {abort_code::kDataLocalControl, "data cannot be transferred or stored because of local control"},
    {abort_code::kDataDeviceState, "data cannot be transferred or stored because of the present device state"},
    {abort_code::kDataObjectDictionary, "object dictionary dynamic generation failed or no object dictionary present"},
    {abort_code::kNoData, "no data available"},
}};

const char* sdo_abort_text(std::uint32_t code) {
  for (const AbortCodeText& e : kAbortCodeTexts) {
    if (e.code == code) return e.text;
  }
  return "unknown abort code";
}

Frame sdo_download(std::uint8_t node, SdoAddress a, std::span<const std::uint8_t> data) {
  Frame f;
  f.id = kCobSdoRx + node;
  f.len = 8;
  const std::size_t n = data.size() > 4 ? 4 : data.size();
  f.data[0] = static_cast<std::uint8_t>(0x23 | ((4 - n) << 2));  // expedited, size indicated
  put16(f.data.data() + 1, a.index);
  f.data[3] = a.sub;
  std::memcpy(f.data.data() + 4, data.data(), n);
  return f;
}

Frame sdo_upload(std::uint8_t node, SdoAddress a) {
  Frame f;
  f.id = kCobSdoRx + node;
  f.len = 8;
  f.data[0] = 0x40;
  put16(f.data.data() + 1, a.index);
  f.data[3] = a.sub;
  return f;
}

Frame sdo_abort(std::uint32_t cob_id, SdoAddress a, std::uint32_t code) {
  Frame f;
  f.id = cob_id;
  f.len = 8;
  f.data[0] = kSdoAbort;
  put16(f.data.data() + 1, a.index);
  f.data[3] = a.sub;
  put32(f.data.data() + 4, code);
  return f;
}

Frame sdo_upload_segment(std::uint8_t node, bool toggle) {
  Frame f;
  f.id = kCobSdoRx + node;
  f.len = 8;
  f.data[0] = static_cast<std::uint8_t>(0x60 | (toggle ? 0x10 : 0));
  return f;
}

Frame sdo_download_initiate(std::uint8_t node, SdoAddress a, std::uint32_t size) {
  Frame f;
  f.id = kCobSdoRx + node;
  f.len = 8;
  f.data[0] = 0x21;  // initiate download, not expedited, size indicated
  put16(f.data.data() + 1, a.index);
  f.data[3] = a.sub;
  put32(f.data.data() + 4, size);
  return f;
}

Frame sdo_download_segment(std::uint8_t node, bool toggle, std::span<const std::uint8_t> chunk, bool last) {
  Frame f;
  f.id = kCobSdoRx + node;
  f.len = 8;
  const std::size_t n = chunk.size() > 7 ? 7 : chunk.size();
  f.data[0] = segment_command(toggle, n, last);
  std::memcpy(f.data.data() + 1, chunk.data(), n);
  return f;
}

Frame sdo_download_ack(std::uint8_t node, SdoAddress a) { return sdo_response(node, 0x60, a, 0); }

Frame sdo_download_segment_ack(std::uint8_t node, bool toggle) {
  return sdo_response(node, static_cast<std::uint8_t>(0x20 | (toggle ? 0x10 : 0)), {}, 0);
}

Frame sdo_upload_expedited(std::uint8_t node, SdoAddress a, std::uint32_t value, std::uint8_t n) {
  n = std::clamp<std::uint8_t>(n, 1, 4);
  if (n < 4) value &= (1u << (8 * n)) - 1;  // the unused bytes are zero
  return sdo_response(node, static_cast<std::uint8_t>(0x43 | ((4 - n) << 2)), a, value);  // expedited, size indicated
}

Frame sdo_upload_segmented_init(std::uint8_t node, SdoAddress a, std::uint32_t size) {
  return sdo_response(node, 0x41, a, size);  // not expedited, size indicated
}

Frame sdo_upload_segment_response(std::uint8_t node, bool toggle, std::span<const std::uint8_t> chunk, bool last) {
  Frame f;
  f.id = kCobSdoTx + node;
  f.len = 8;
  const std::size_t n = chunk.size() > 7 ? 7 : chunk.size();
  f.data[0] = segment_command(toggle, n, last);
  if (n) std::memcpy(f.data.data() + 1, chunk.data(), n);
  return f;
}

SdoResponse decode_sdo_response(const Frame& f) {
  SdoResponse r;
  if (!standard(f) || f.len != 8) return r;
  const std::uint8_t cmd = f.data[0];
  const std::uint8_t scs = cmd >> 5;
  r.address = {get16(f.data.data() + 1), f.data[3]};
  if (cmd == kSdoAbort) {
    r.type = SdoResponse::Type::kAbort;
    r.abort_code = get32(f.data.data() + 4);
    return r;
  }
  switch (scs) {
    case 3:  // download initiate response
      r.type = SdoResponse::Type::kDownloadAck;
      return r;
    case 2: {  // upload initiate response
      const bool expedited = cmd & 0x02, size_indicated = cmd & 0x01;
      if (expedited) {
        r.type = SdoResponse::Type::kUploadExpedited;
        r.size = size_indicated ? static_cast<std::uint8_t>(4 - ((cmd >> 2) & 0x3)) : 4;
        r.value = get32(f.data.data() + 4);
        if (r.size < 4) r.value &= (1u << (8 * r.size)) - 1;
      } else {
        r.type = SdoResponse::Type::kUploadSegmentedInit;
        r.value = size_indicated ? get32(f.data.data() + 4) : 0;
      }
      return r;
    }
    case 0:  // upload segment response
      r.type = SdoResponse::Type::kUploadSegment;
      r.toggle = cmd & 0x10;
      r.last = cmd & 0x01;
      r.size = static_cast<std::uint8_t>(7 - ((cmd >> 1) & 0x7));
      std::memcpy(r.segment.data(), f.data.data() + 1, 7);
      r.address = {};
      return r;
    case 1:  // download segment response
      r.type = SdoResponse::Type::kDownloadSegmentAck;
      r.toggle = cmd & 0x10;
      r.address = {};
      return r;
    default:
      return r;
  }
}

bool pack_pdo(std::span<const PdoField> fields, std::span<const std::int64_t> values, Frame* f) {
  std::size_t bit = 0;
  f->data.fill(0);
  for (std::size_t i = 0; i < fields.size() && i < values.size(); ++i) {
    const std::size_t bytes = fields[i].bits / 8;
    if (bit / 8 + bytes > 8 || fields[i].bits % 8) return false;
    const auto v = static_cast<std::uint64_t>(values[i]);
    for (std::size_t b = 0; b < bytes; ++b) f->data[bit / 8 + b] = static_cast<std::uint8_t>(v >> (8 * b));
    bit += fields[i].bits;
  }
  f->len = static_cast<std::uint8_t>(bit / 8);
  return true;
}

bool unpack_pdo(const Frame& f, std::span<const PdoField> fields, std::span<std::int64_t> values) {
  std::size_t byte = 0;
  for (std::size_t i = 0; i < fields.size() && i < values.size(); ++i) {
    const std::size_t bytes = fields[i].bits / 8;
    if (byte + bytes > f.len || fields[i].bits % 8 || bytes == 0 || bytes > 8) return false;
    std::uint64_t v = 0;
    for (std::size_t b = 0; b < bytes; ++b) v |= static_cast<std::uint64_t>(f.data[byte + b]) << (8 * b);
    if (fields[i].is_signed && bytes < 8 && (v >> (8 * bytes - 1)) & 1) v |= ~0ull << (8 * bytes);  // sign-extend
    values[i] = static_cast<std::int64_t>(v);
    byte += bytes;
  }
  return true;
}

}  // namespace cairn::canopen
