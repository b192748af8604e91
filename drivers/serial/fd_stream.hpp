// Byte streams over file descriptors: termios ttys/ptys and TCP sockets.
#pragma once

#include <sys/socket.h>
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
  IoError set_baud(std::uint32_t baud) override;
  bool can_set_baud() const override { return true; }
  std::uint32_t baud() const override { return baud_; }
  void flush_input() override;
  IoError reopen() override;
  std::string describe() const override { return "tty:" + path_; }

 private:
  TtyStream(std::string path, std::uint32_t baud) : path_(std::move(path)), baud_(baud) {}
  IoError open_fd();
  std::string path_;
  std::uint32_t baud_;
  int fd_ = -1;
};

/// A TCP client to a serial device server. The address is resolved once, at open (a
/// name lookup may block); open() waits for the connection up to kOpenConnectWait.
/// reopen() never waits: it starts a non-blocking connect and returns kConnecting until a
/// later call finds it established, so the laser's I/O thread is never held by a device
/// server that does not answer.
class TcpStream final : public ByteStream {
 public:
  static std::unique_ptr<TcpStream> open(const std::string& host, const std::string& port, std::uint32_t baud,
                                         std::string* error);
  ~TcpStream() override;
  IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) override;
  IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) override;
  IoError set_baud(std::uint32_t baud) override;
  bool can_set_baud() const override { return false; }
  std::uint32_t baud() const override { return baud_; }
  void flush_input() override;
  IoError reopen() override;
  std::string describe() const override { return "tcp:" + host_ + ":" + port_; }

 private:
  static constexpr Nanos kOpenConnectWait = 2 * kNanosPerSecond;
  TcpStream(std::string host, std::string port, std::uint32_t baud) : host_(std::move(host)), port_(std::move(port)), baud_(baud) {}
  bool resolve(std::string* error);
  /// Starts a connect, or checks the one under way; ok once established. `wait`: how
  /// long to wait for it here (0 at a reopen).
  IoError connect_fd(Nanos wait);
  void established(int fd);
  std::string host_, port_;
  std::uint32_t baud_;
  sockaddr_storage addr_{};
  socklen_t addr_len_ = 0;
  int fd_ = -1;
  int pending_ = -1;  // a connect under way
};

/// The termios speed for a baud rate (B0 for one termios cannot name).
speed_t termios_speed(std::uint32_t baud);

/// Shared poll-based I/O on a non-blocking fd.
IoResult fd_read(int fd, std::span<std::uint8_t> buffer, Nanos timeout);
/// On a socket (`socket`), a peer that went away is kClosed (EPIPE), never a SIGPIPE.
IoResult fd_write(int fd, std::span<const std::uint8_t> bytes, Nanos timeout, bool socket = false);

}  // namespace cairn::serial
