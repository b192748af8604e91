// A real UART through libserialport (8N1, no flow control). libserialport finds, opens
// and configures the port; streaming then works on its file descriptor
// (sp_get_port_handle) with poll()/read()/write(), like TtyStream:
//  - a zero timeout means "do not wait" (libserialport's sp_wait, sp_blocking_read and
//    sp_blocking_write take 0 as "wait forever");
//  - nothing allocates while streaming (sp_wait mallocs its pollfd array on every call).
// Note: Debian's libserialport 0.1.1 cannot open a pty (it needs a sysfs tty), so this
// backend is exercised for real in the VM bench; ptys use TtyStream (tty:).
#pragma once

#include "drivers/serial/byte_stream.hpp"

struct sp_port;

namespace cairn::serial {

class SerialPortStream final : public ByteStream {
 public:
  static std::unique_ptr<SerialPortStream> open(const std::string& name, std::uint32_t baud, std::string* error);
  ~SerialPortStream() override;
  IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) override;
  IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) override;
  IoError set_baud(std::uint32_t baud) override;
  bool can_set_baud() const override { return true; }
  std::uint32_t baud() const override { return baud_; }
  void flush_input() override;
  IoError reopen() override;
  std::string describe() const override { return "serial:" + name_; }

 private:
  SerialPortStream(std::string name, std::uint32_t baud) : name_(std::move(name)), baud_(baud) {}
  IoError open_port();  // on port_, found at open(): allocates nothing
  void close_port();
  std::string name_;
  std::uint32_t baud_;
  sp_port* port_ = nullptr;  // found once, at open(); kept across reopens
  int fd_ = -1;              // port_'s descriptor while open (owned by libserialport), non-blocking
};

}  // namespace cairn::serial
