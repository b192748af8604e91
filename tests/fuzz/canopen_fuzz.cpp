// libFuzzer target: CANopen frame decoding (SDO responses, EMCY, heartbeat, PDOs, the
// CiA 402 statusword) on arbitrary frames, and the SDO server's responses built from the
// same bytes decoding back to them. Input: 4 bytes id, 1 byte len, 8 data bytes, repeated.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "drivers/canopen/canopen_codec.hpp"
#include "drivers/canopen/cia402.hpp"

using namespace cairn;

namespace {
// decode_sdo_response(encode(x)) == x for every server response (a mismatch traps).
void server_responses_round_trip(const std::uint8_t* b) {
  using canopen::SdoResponse;
  const canopen::SdoAddress a{static_cast<std::uint16_t>(b[0] | (b[1] << 8)), b[2]};
  const std::uint8_t node = b[3] & 0x7F;
  std::uint32_t value;
  std::memcpy(&value, b + 4, 4);
  const bool toggle = b[8] & 1, last = b[8] & 2;
  const std::uint8_t n = static_cast<std::uint8_t>(1 + (b[8] >> 2) % 4);  // expedited: 1..4 bytes
  const std::size_t seg = (b[8] >> 4) % 8;                                 // segment: 0..7 bytes
  SdoResponse r = canopen::decode_sdo_response(canopen::sdo_upload_expedited(node, a, value, n));
  const std::uint32_t low = n == 4 ? value : value & ((1u << (8 * n)) - 1);
  if (r.type != SdoResponse::Type::kUploadExpedited || r.size != n || r.value != low || r.address.index != a.index || r.address.sub != a.sub)
    __builtin_trap();
  r = canopen::decode_sdo_response(canopen::sdo_download_ack(node, a));
  if (r.type != SdoResponse::Type::kDownloadAck || r.address.index != a.index || r.address.sub != a.sub) __builtin_trap();
  r = canopen::decode_sdo_response(canopen::sdo_upload_segmented_init(node, a, value));
  if (r.type != SdoResponse::Type::kUploadSegmentedInit || r.value != value || r.address.index != a.index) __builtin_trap();
  r = canopen::decode_sdo_response(canopen::sdo_upload_segment_response(node, toggle, {b + 1, seg}, last));
  if (r.type != SdoResponse::Type::kUploadSegment || r.size != seg || r.toggle != toggle || r.last != last ||
      std::memcmp(r.segment.data(), b + 1, seg) != 0)
    __builtin_trap();
  r = canopen::decode_sdo_response(canopen::sdo_download_segment_ack(node, toggle));
  if (r.type != SdoResponse::Type::kDownloadSegmentAck || r.toggle != toggle) __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (std::size_t off = 0; off + 13 <= size; off += 13) {
    can::Frame f;
    std::memcpy(&f.id, data + off, 4);
    f.len = data[off + 4];  // may be > 8: decoders must not trust it
    std::memcpy(f.data.data(), data + off + 5, 8);
    if (f.len > 8) f.len = static_cast<std::uint8_t>(f.len % 9);
    canopen::classify(f.id);
    canopen::decode_sdo_response(f);
    canopen::decode_emcy(f);
    canopen::decode_heartbeat(f);
    const canopen::PdoField fields[] = {{16, false}, {32, true}, {8, true}, {8, false}};
    std::int64_t values[4];
    canopen::unpack_pdo(f, fields, values);
    const std::uint16_t sw = static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8));
    cia402::next_controlword(cia402::decode(sw), cia402::State::kOperationEnabled, f.data[2]);
    canopen::emcy_text(sw);
    canopen::sdo_abort_text(static_cast<std::uint32_t>(f.id));
    server_responses_round_trip(data + off + 4);  // len + data: 9 bytes
  }
  return 0;
}
