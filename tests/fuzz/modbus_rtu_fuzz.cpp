// libFuzzer target: Modbus RTU response handling. Arbitrary bytes play the power board's
// replies on the serial line, through libmodbus's real RTU client parser (frame length
// from the function code, slave-id check, CRC-16 check, exception replies) over a
// socketpair standing in for the tty (libmodbus' RTU backend reads and writes its fd
// with read()/write()/select(); only modbus_connect() needs a real tty), then our decoder
// checks the values. This is poll()'s sequence: input registers, then the e-stop input.
//
// Input: byte 0 = flags, byte 1 = where the first reply ends, then the reply bytes.
// Flag bit 0 appends the correct CRC-16 to each reply, so the fuzzer gets past the CRC
// check to the parser behind it; without it the raw bytes (bad CRCs included) are sent.
#include <modbus/modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "drivers/modbus/power_board.hpp"

namespace {

// Modbus RTU CRC-16 (poly 0xA001 reflected, init 0xFFFF), low byte first on the wire.
std::uint16_t crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

void append_reply(std::vector<std::uint8_t>* out, const std::uint8_t* p, std::size_t n, bool fix_crc) {
  out->insert(out->end(), p, p + n);
  if (fix_crc && n > 0) {
    const std::uint16_t c = crc16(p, n);
    out->push_back(static_cast<std::uint8_t>(c & 0xFF));
    out->push_back(static_cast<std::uint8_t>(c >> 8));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const bool fix_crc = data[0] & 1;
  const std::size_t payload = size - 2;
  const std::size_t split = data[1] < payload ? data[1] : payload;
  std::vector<std::uint8_t> wire;
  append_reply(&wire, data + 2, split, fix_crc);
  append_reply(&wire, data + 2 + split, payload - split, fix_crc);

  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) return 0;
  modbus_t* ctx = modbus_new_rtu("/dev/null", 115200, 'N', 8, 1);  // never connected: the socket is the line
  if (!ctx) {
    ::close(sv[0]);
    ::close(sv[1]);
    return 0;
  }
  modbus_set_slave(ctx, 1);
  modbus_set_socket(ctx, sv[0]);
  modbus_set_response_timeout(ctx, 0, 1000);
  modbus_set_byte_timeout(ctx, 0, 1000);
  // The "board" has already answered: the fuzz bytes, then the line goes quiet.
  if (!wire.empty()) {
    const ssize_t w = ::write(sv[1], wire.data(), wire.size());
    (void)w;
  }
  ::shutdown(sv[1], SHUT_WR);
  std::uint16_t regs[4] = {};
  std::uint8_t bit = 0;
  if (modbus_read_input_registers(ctx, 0, 4, regs) == 4 && modbus_read_input_bits(ctx, 0, 1, &bit) == 1) {
    cairn::modbus::PowerState s;
    cairn::modbus::decode_power(regs, bit != 0, {}, &s);
  }
  modbus_free(ctx);  // does not close the socket it was given
  ::close(sv[0]);
  ::close(sv[1]);
  return 0;
}
