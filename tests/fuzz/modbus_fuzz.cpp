// libFuzzer target: Modbus response handling. Arbitrary bytes play the power board's
// reply to each request through libmodbus's real client parser (over a socketpair),
// then our decoder checks the values.
#include <modbus/modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>

#include "drivers/modbus/power_board.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) return 0;
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 1502);
  modbus_set_socket(ctx, sv[0]);
  modbus_set_response_timeout(ctx, 0, 1000);
  modbus_set_byte_timeout(ctx, 0, 1000);
  // The "server" has already written its reply: the fuzz bytes.
  if (size > 0) {
    const ssize_t w = ::write(sv[1], data, size);
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
