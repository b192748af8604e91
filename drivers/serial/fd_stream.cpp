#include "drivers/serial/fd_stream.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cairn::serial {

speed_t termios_speed(std::uint32_t baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 500000: return B500000;
    default: return B0;
  }
}

IoResult fd_read(int fd, std::span<std::uint8_t> buffer, Nanos timeout) {
  if (fd < 0) return {IoResult::Status::kClosed, 0, EBADF};
  pollfd p{fd, POLLIN, 0};
  const int r = poll(&p, 1, timeout_to_ms(timeout));
  if (r == 0) return {IoResult::Status::kTimeout, 0, 0};
  if (r < 0) return errno == EINTR ? IoResult{IoResult::Status::kTimeout, 0, 0} : IoResult{IoResult::Status::kError, 0, errno};
  const ssize_t n = ::read(fd, buffer.data(), buffer.size());
  if (n > 0) return {IoResult::Status::kOk, static_cast<std::size_t>(n), 0};
  if (n == 0) return {IoResult::Status::kClosed, 0, 0};
  if (errno == EAGAIN || errno == EINTR) return {IoResult::Status::kTimeout, 0, 0};
  if (errno == EIO) return {IoResult::Status::kClosed, 0, EIO};  // pty peer gone, USB adapter unplugged
  return {IoResult::Status::kError, 0, errno};
}

IoResult fd_write(int fd, std::span<const std::uint8_t> bytes, Nanos timeout, bool socket) {
  if (fd < 0) return {IoResult::Status::kClosed, 0, EBADF};
  const Nanos deadline = MonotonicClock::instance().now() + timeout;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = socket ? ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL)
                             : ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) {
      return {errno == EIO || errno == EPIPE || errno == ECONNRESET ? IoResult::Status::kClosed : IoResult::Status::kError, done, errno};
    }
    const Nanos left = deadline - MonotonicClock::instance().now();
    if (left <= 0) return {IoResult::Status::kTimeout, done, 0};
    pollfd p{fd, POLLOUT, 0};
    poll(&p, 1, timeout_to_ms(left));
  }
  return {IoResult::Status::kOk, done, 0};
}

// ---------------------------------------------------------------- tty

std::unique_ptr<TtyStream> TtyStream::open(const std::string& path, std::uint32_t baud, std::string* error) {
  std::unique_ptr<TtyStream> s(new TtyStream(path, baud));
  if (const IoError e = s->open_fd(); !e.ok()) {
    *error = s->describe() + ": cannot open" + (e.code == IoErrc::kBadBaud ? " at " + std::to_string(baud) + " baud" : "") +
             ": " + io_errc_text(e.code) + (e.sys ? std::string(" (") + e.sys_text() + ")" : "");
    return nullptr;
  }
  return s;
}

TtyStream::~TtyStream() {
  if (fd_ >= 0) ::close(fd_);
}

IoError TtyStream::open_fd() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) return io_error_from_errno(errno);
  if (const IoError e = set_baud(baud_); !e.ok()) {
    ::close(fd_);
    fd_ = -1;
    return e;
  }
  return {};
}

IoError TtyStream::set_baud(std::uint32_t baud) {
  const speed_t sp = termios_speed(baud);
  if (!sp) return {IoErrc::kBadBaud, 0};
  termios t{};
  if (tcgetattr(fd_, &t) != 0) return {IoErrc::kNotATerminal, errno};
  cfmakeraw(&t);  // 8 data bits, no parity, no echo, no translation
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  cfsetispeed(&t, sp);
  cfsetospeed(&t, sp);
  if (tcsetattr(fd_, TCSANOW, &t) != 0) return {IoErrc::kBadBaud, errno};
  baud_ = baud;
  return {};
}

IoResult TtyStream::read(std::span<std::uint8_t> buffer, Nanos timeout) { return fd_read(fd_, buffer, timeout); }
IoResult TtyStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) { return fd_write(fd_, bytes, timeout); }
void TtyStream::flush_input() {
  if (fd_ >= 0) tcflush(fd_, TCIFLUSH);
}
IoError TtyStream::reopen() { return open_fd(); }

// ---------------------------------------------------------------- tcp

std::unique_ptr<TcpStream> TcpStream::open(const std::string& host, const std::string& port, std::uint32_t baud,
                                           std::string* error) {
  std::unique_ptr<TcpStream> s(new TcpStream(host, port, baud));
  if (!s->resolve(error)) return nullptr;
  IoError e;
  for (std::size_t i = 0; i < s->n_addrs_; ++i) {  // each address once, kOpenConnectWait each
    e = s->connect_fd(kOpenConnectWait);
    if (e.ok()) return s;
    s->drop_pending();
  }
  *error = s->describe() + ": cannot connect: " + io_errc_text(e.code) + (e.sys ? std::string(" (") + e.sys_text() + ")" : "");
  return nullptr;
}

TcpStream::~TcpStream() {
  if (fd_ >= 0) ::close(fd_);
  if (pending_ >= 0) ::close(pending_);
}

bool TcpStream::resolve(std::string* error) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(host_.c_str(), port_.c_str(), &hints, &res);
  if (rc != 0 || !res) {
    *error = describe() + ": cannot resolve: " + gai_strerror(rc);
    return false;
  }
  n_addrs_ = 0;
  for (const addrinfo* a = res; a && n_addrs_ < kMaxAddresses; a = a->ai_next) {
    std::memcpy(&addrs_[n_addrs_], a->ai_addr, a->ai_addrlen);
    addr_lens_[n_addrs_++] = a->ai_addrlen;
  }
  freeaddrinfo(res);
  return true;
}

void TcpStream::established(int fd) {
  fd_ = fd;
  const int one = 1;
  setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

void TcpStream::drop_pending() {
  if (pending_ >= 0) ::close(pending_);
  pending_ = -1;
  next_addr_ = (next_addr_ + 1) % n_addrs_;
}

IoError TcpStream::connect_fd(Nanos wait) {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  const Nanos now = MonotonicClock::instance().now();
  if (pending_ >= 0 && now - pending_since_ > kPendingLimit) drop_pending();  // start afresh
  if (pending_ < 0) {
    const sockaddr_storage& addr = addrs_[next_addr_];
    pending_ = ::socket(addr.ss_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (pending_ < 0) return io_error_from_errno(errno);
    pending_since_ = now;
    if (::connect(pending_, reinterpret_cast<const sockaddr*>(&addr), addr_lens_[next_addr_]) == 0) {
      established(pending_);
      pending_ = -1;
      return {};
    }
    if (errno != EINPROGRESS) {
      const IoError e = io_error_from_errno(errno);
      drop_pending();
      return e;
    }
  }
  pollfd p{pending_, POLLOUT, 0};
  if (poll(&p, 1, timeout_to_ms(wait)) <= 0) return {IoErrc::kConnecting, 0};  // a later call looks again
  int e = 0;
  socklen_t len = sizeof e;
  getsockopt(pending_, SOL_SOCKET, SO_ERROR, &e, &len);
  if (e != 0) {
    drop_pending();
    return io_error_from_errno(e);
  }
  established(pending_);
  pending_ = -1;
  return {};
}

IoResult TcpStream::read(std::span<std::uint8_t> buffer, Nanos timeout) { return fd_read(fd_, buffer, timeout); }
IoResult TcpStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) { return fd_write(fd_, bytes, timeout, true); }

// A raw TCP link cannot change the device server's baud rate: that is configured there.
IoError TcpStream::set_baud(std::uint32_t baud) { return baud == baud_ ? IoError{} : IoError{IoErrc::kUnsupported, 0}; }

void TcpStream::flush_input() {
  std::uint8_t buf[512];
  while (fd_read(fd_, buf, 0).ok()) {
  }
}

IoError TcpStream::reopen() { return connect_fd(0); }

}  // namespace cairn::serial
