// Byte streams over file descriptors: termios ttys/ptys and TCP sockets.
#pragma once

#include <sys/socket.h>
#include <termios.h>

#include <array>

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

/// A TCP client to a serial device server. The name is resolved once, at open (a lookup
/// may block), to at most kMaxAddresses addresses; open() waits for a connection up to
/// kOpenConnectWait per address. reopen() never waits: it starts a non-blocking connect
/// and returns kConnecting until a later call finds it established, so the laser's I/O
/// thread is never held by a device server that does not answer. A connect still pending
/// after kPendingLimit is dropped and a fresh one started (the kernel's own SYN retries
/// back off to half a minute and more), and a refused one moves on to the next address.
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
  static constexpr Nanos kPendingLimit = 2 * kNanosPerSecond;
  static constexpr std::size_t kMaxAddresses = 4;
  TcpStream(std::string host, std::string port, std::uint32_t baud) : host_(std::move(host)), port_(std::move(port)), baud_(baud) {}
  bool resolve(std::string* error);
  /// Starts a connect, or checks the one under way; ok once established. `wait`: how
  /// long to wait for it here (0 at a reopen).
  IoError connect_fd(Nanos wait);
  void drop_pending();  // closes a connect under way; the next tries the next address
  void established(int fd);
  std::string host_, port_;
  std::uint32_t baud_;
  std::array<sockaddr_storage, kMaxAddresses> addrs_{};
  std::array<socklen_t, kMaxAddresses> addr_lens_{};
  std::size_t n_addrs_ = 0, next_addr_ = 0;  // the address the next connect tries
  int fd_ = -1;
  int pending_ = -1;          // a connect under way
  Nanos pending_since_ = 0;
};

/// The termios speed for a baud rate (B0 for one termios cannot name).
speed_t termios_speed(std::uint32_t baud);

/// Shared poll-based I/O on a non-blocking fd.
IoResult fd_read(int fd, std::span<std::uint8_t> buffer, Nanos timeout);
/// On a socket (`socket`), a peer that went away is kClosed (EPIPE), never a SIGPIPE.
IoResult fd_write(int fd, std::span<const std::uint8_t> bytes, Nanos timeout, bool socket = false);

}  // namespace cairn::serial
