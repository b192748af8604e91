// Byte streams over file descriptors: termios ttys/ptys and TCP sockets.
#pragma once

#include <termios.h>

#include "drivers/serial/byte_stream.hpp"

namespace cairn::serial {

/// A tty or pty opened by path, configured raw 8N1 with termios.
class TtyStream final : public ByteStream {
 public:
  static std::unique_ptr<TtyStream> open(const std::string& path, std::uint32_t baud, std::string* error);
  ~TtyStream() override;
  IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) override;
  IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) override;
  bool set_baud(std::uint32_t baud, std::string* error) override;
  bool can_set_baud() const override { return true; }
  std::uint32_t baud() const override { return baud_; }
  void flush_input() override;
  bool reopen(std::string* error) override;
  std::string describe() const override { return "tty:" + path_; }

 private:
  TtyStream(std::string path, std::uint32_t baud) : path_(std::move(path)), baud_(baud) {}
  bool open_fd(std::string* error);
  std::string path_;
  std::uint32_t baud_;
  int fd_ = -1;
};

/// A TCP client to a serial device server.
class TcpStream final : public ByteStream {
 public:
  static std::unique_ptr<TcpStream> open(const std::string& host, const std::string& port, std::uint32_t baud,
                                         std::string* error);
  ~TcpStream() override;
  IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) override;
  IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) override;
  bool set_baud(std::uint32_t baud, std::string* error) override;
  bool can_set_baud() const override { return false; }
  std::uint32_t baud() const override { return baud_; }
  void flush_input() override;
  bool reopen(std::string* error) override;
  std::string describe() const override { return "tcp:" + host_ + ":" + port_; }

 private:
  TcpStream(std::string host, std::string port, std::uint32_t baud) : host_(std::move(host)), port_(std::move(port)), baud_(baud) {}
  bool connect_fd(std::string* error);
  std::string host_, port_;
  std::uint32_t baud_;
  int fd_ = -1;
};

/// The termios speed for a baud rate (B0 for one termios cannot name).
speed_t termios_speed(std::uint32_t baud);

/// Shared poll-based I/O on a non-blocking fd.
IoResult fd_read(int fd, std::span<std::uint8_t> buffer, Nanos timeout);
/// On a socket (`socket`), a peer that went away is kClosed (EPIPE), never a SIGPIPE.
IoResult fd_write(int fd, std::span<const std::uint8_t> bytes, Nanos timeout, bool socket = false);

}  // namespace cairn::serial
