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
  if (!s->open_fd(error)) return nullptr;
  return s;
}

TtyStream::~TtyStream() {
  if (fd_ >= 0) ::close(fd_);
}

bool TtyStream::open_fd(std::string* error) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    *error = "tty:" + path_ + ": cannot open: " + std::strerror(errno);
    return false;
  }
  if (!set_baud(baud_, error)) {
    ::close(fd_);
    fd_ = -1;
    return false;
  }
  return true;
}

bool TtyStream::set_baud(std::uint32_t baud, std::string* error) {
  const speed_t sp = termios_speed(baud);
  if (!sp) {
    *error = "tty:" + path_ + ": unsupported baud rate " + std::to_string(baud);
    return false;
  }
  termios t{};
  if (tcgetattr(fd_, &t) != 0) {
    *error = "tty:" + path_ + ": not a terminal (tcgetattr: " + std::strerror(errno) + ")";
    return false;
  }
  cfmakeraw(&t);  // 8 data bits, no parity, no echo, no translation
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  cfsetispeed(&t, sp);
  cfsetospeed(&t, sp);
  if (tcsetattr(fd_, TCSANOW, &t) != 0) {
    *error = "tty:" + path_ + ": cannot set " + std::to_string(baud) + " baud: " + std::strerror(errno);
    return false;
  }
  baud_ = baud;
  return true;
}

IoResult TtyStream::read(std::span<std::uint8_t> buffer, Nanos timeout) { return fd_read(fd_, buffer, timeout); }
IoResult TtyStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) { return fd_write(fd_, bytes, timeout); }
void TtyStream::flush_input() {
  if (fd_ >= 0) tcflush(fd_, TCIFLUSH);
}
bool TtyStream::reopen(std::string* error) { return open_fd(error); }

// ---------------------------------------------------------------- tcp

std::unique_ptr<TcpStream> TcpStream::open(const std::string& host, const std::string& port, std::uint32_t baud,
                                           std::string* error) {
  std::unique_ptr<TcpStream> s(new TcpStream(host, port, baud));
  if (!s->connect_fd(error)) return nullptr;
  return s;
}

TcpStream::~TcpStream() {
  if (fd_ >= 0) ::close(fd_);
}

bool TcpStream::connect_fd(std::string* error) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(host_.c_str(), port_.c_str(), &hints, &res);
  if (rc != 0) {
    *error = describe() + ": cannot resolve: " + gai_strerror(rc);
    return false;
  }
  int last = 0;
  for (addrinfo* a = res; a; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    if (::connect(fd, a->ai_addr, a->ai_addrlen) == 0) {
      fd_ = fd;
      break;
    }
    last = errno;
    ::close(fd);
  }
  freeaddrinfo(res);
  if (fd_ < 0) {
    *error = describe() + ": cannot connect: " + std::strerror(last);
    return false;
  }
  const int one = 1;
  setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
  return true;
}

IoResult TcpStream::read(std::span<std::uint8_t> buffer, Nanos timeout) { return fd_read(fd_, buffer, timeout); }
IoResult TcpStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) { return fd_write(fd_, bytes, timeout, true); }

bool TcpStream::set_baud(std::uint32_t baud, std::string* error) {
  if (baud == baud_) return true;
  *error = describe() + ": a raw TCP link cannot change the device server's baud rate (configure it there)";
  return false;
}

void TcpStream::flush_input() {
  std::uint8_t buf[512];
  while (fd_read(fd_, buf, 0).ok()) {
  }
}

bool TcpStream::reopen(std::string* error) { return connect_fd(error); }

}  // namespace cairn::serial
