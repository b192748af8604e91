// libFuzzer target: CANopen frame decoding (SDO responses, EMCY, heartbeat, PDOs, the
// CiA 402 statusword) on arbitrary frames. Input: 4 bytes id, 1 byte len, 8 data bytes, repeated.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "drivers/canopen/canopen_codec.hpp"
#include "drivers/canopen/cia402.hpp"

using namespace cairn;

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
  }
  return 0;
}
