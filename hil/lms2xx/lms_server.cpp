#include "hil/lms2xx/lms_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "drivers/serial/fd_stream.hpp"

namespace cairn::hil {

namespace {
std::uint32_t baud_of_speed(speed_t s) {
  switch (s) {
    case B9600: return 9600;
    case B19200: return 19200;
    case B38400: return 38400;
    case B57600: return 57600;
    case B115200: return 115200;
    case B500000: return 500000;
    default: return 0;
  }
}
}  // namespace

LmsServer::LmsServer(Link link, LmsDeviceConfig cfg, const World* world, LmsDevice::PoseSource pose, int tcp_port,
                     const std::string& uart)
    : link_(link), device_(std::make_unique<LmsDevice>(std::move(cfg), world, std::move(pose))) {
  if (link == Link::kUart) {
    fd_ = ::open(uart.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    termios t{};
    bool ok = fd_ >= 0 && tcgetattr(fd_, &t) == 0;
    if (ok) {
      cfmakeraw(&t);
      t.c_cflag |= CLOCAL | CREAD;
      t.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS);
      ok = tcsetattr(fd_, TCSANOW, &t) == 0;
    }
    if (!ok) {
      const int e = errno;
      if (fd_ >= 0) ::close(fd_);
      throw std::runtime_error("lms server: cannot open the UART " + uart + " raw: " + std::strerror(e));
    }
    uri_ = "tty:" + uart;
  } else if (link == Link::kPty) {
    int slave = -1;
    char name[128];
    if (openpty(&fd_, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error(std::string("openpty: ") + std::strerror(errno));
    // Keep the slave open so the master never sees a hang-up between host opens; raw mode.
    termios t{};
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    cfsetspeed(&t, B9600);
    tcsetattr(slave, TCSANOW, &t);
    fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
    uri_ = std::string("tty:") + name;
    // The slave fd stays open for the server's lifetime (closed in the destructor via fd table).
    listen_fd_ = slave;
  } else {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(tcp_port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);  // loopback only
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listen_fd_, 1) != 0) {
      throw std::runtime_error(std::string("lms server: cannot listen on 127.0.0.1: ") + std::strerror(errno));
    }
    socklen_t len = sizeof a;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    fcntl(listen_fd_, F_SETFL, fcntl(listen_fd_, F_GETFL) | O_NONBLOCK);
    uri_ = "tcp:127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  }
}

LmsServer::~LmsServer() {
  stop();
  // A UART's close waits (up to the port's closing_wait, 30 s) for unsent bytes to drain,
  // and with nobody reading at the other end they never do: drop them.
  if (link_ == Link::kUart && fd_ >= 0) tcflush(fd_, TCIOFLUSH);
  if (fd_ >= 0) ::close(fd_);
  if (listen_fd_ >= 0) ::close(listen_fd_);
}

void LmsServer::start() {
  {
    std::lock_guard lock(mutex_);
    device_->power_on(MonotonicClock::instance().now());
  }
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void LmsServer::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
}

int LmsServer::accept_client() {
  const int c = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
  if (c >= 0) {
    const int one = 1;
    setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  return c;
}

void LmsServer::run() {
  auto& clock = MonotonicClock::instance();
  while (running_) {
    const Nanos now = clock.now();
    serve_once(now);
    // Fine pacing: wake every 200 µs (a byte takes 20 µs at 500 kBd, 1 ms at 9600).
    clock.sleep_until(now + 200 * kNanosPerMicro);
  }
}

void LmsServer::serve_once(Nanos now) {
  std::lock_guard lock(mutex_);
  if (link_ == Link::kTcp && fd_ < 0) {
    fd_ = accept_client();
    tx_credit_time_ = now;
  }
  std::uint32_t host = device_->baud();
  if (link_ == Link::kUart && uart_baud_ != host) {
    // The device switched its rate (or just booted): its UART follows, once per change.
    uart_baud_ = host;
    termios t{};
    const speed_t s = serial::termios_speed(host);
    if (s == B0 || tcgetattr(fd_, &t) != 0 || cfsetspeed(&t, s) != 0 || tcsetattr(fd_, TCSANOW, &t) != 0) uart_refused_ = host;
  }
  if (link_ == Link::kPty && fd_ >= 0) {
    termios t{};
    if (tcgetattr(fd_, &t) == 0) host = baud_of_speed(cfgetispeed(&t));
  }
  host_baud_ = host;
  const bool mismatch = host != device_->baud();
  // Host -> device.
  std::uint8_t buf[4096];
  if (fd_ >= 0) {
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0 && !unplugged_) {
      if (mismatch) {
        for (ssize_t i = 0; i < n; ++i) buf[i] = static_cast<std::uint8_t>(noise_());  // framing garbage
      }
      device_->receive({buf, static_cast<std::size_t>(n)}, now);
    } else if (n == 0 && link_ == Link::kTcp) {
      ::close(fd_);  // client went away; wait for the next one
      fd_ = -1;
    }
  }
  device_->poll(now, device_->tx().empty());
  // Device -> host, paced at the device's baud.
  const auto& tx = device_->tx();
  if (tx.empty()) {
    tx_credit_time_ = now;
    if (was_busy_) {
      device_->on_tx_drained(now);
      was_busy_ = false;
    }
    return;
  }
  if (!was_busy_) tx_credit_time_ = now;
  const double bytes_per_ns = static_cast<double>(device_->baud()) / 10.0 / 1e9;
  std::size_t budget = static_cast<std::size_t>(static_cast<double>(now - tx_credit_time_) * bytes_per_ns);
  if (!was_busy_) budget = std::max<std::size_t>(budget, 1);  // the first byte leaves now
  budget = std::min(budget, std::min(tx.size(), sizeof buf));
  if (budget == 0) return;
  // Stamp a scan's first byte with its ideal time on the line.
  const std::uint64_t first = device_->popped();
  auto& sent = device_->sent_scans();
  for (auto it = sent.rbegin(); it != sent.rend() && it->first_byte + it->bytes > first; ++it) {  // newest first
    if (it->tx_start < 0 && it->first_byte >= first && it->first_byte < first + budget) {
      it->tx_start = tx_credit_time_ + static_cast<Nanos>(static_cast<double>(it->first_byte - first) / bytes_per_ns);
    }
  }
  for (std::size_t i = 0; i < budget; ++i) {
    const std::uint8_t b = device_->pop_tx();
    buf[i] = mismatch ? static_cast<std::uint8_t>(noise_()) : b;
  }
  was_busy_ = true;
  tx_credit_time_ += static_cast<Nanos>(static_cast<double>(budget) / bytes_per_ns);
  if (unplugged_ || fd_ < 0) return;  // bytes go nowhere
  // A full pty or UART buffer drops bytes, as a UART overrun would; a TCP client that went away is
  // noticed by the next read (MSG_NOSIGNAL: no SIGPIPE for the process the bench runs in).
  // Stamped before the write: a host reader woken by it can preempt this thread before
  // the write returns, so a stamp taken after would come after the host's reaction.
  const Nanos written = MonotonicClock::instance().now();
  const ssize_t w = link_ == Link::kTcp ? ::send(fd_, buf, budget, MSG_NOSIGNAL) : ::write(fd_, buf, budget);
  (void)w;
  for (auto it = sent.rbegin(); it != sent.rend() && it->first_byte + it->bytes > first; ++it) {
    if (it->last_byte_written < 0 && it->first_byte + it->bytes <= first + budget) it->last_byte_written = written;
  }
}

void LmsServer::unplug(bool unplugged) { unplugged_ = unplugged; }
void LmsServer::power_cycle() {
  std::lock_guard lock(mutex_);
  device_->power_on(MonotonicClock::instance().now());
  was_busy_ = false;
}
void LmsServer::inject_garbage(std::size_t n) {
  std::lock_guard lock(mutex_);
  device_->inject_garbage(n);
}
void LmsServer::corrupt_next_crc() {
  std::lock_guard lock(mutex_);
  device_->corrupt_next_telegram_crc();
}
void LmsServer::drop_bytes(std::size_t n) {
  std::lock_guard lock(mutex_);
  device_->drop_from_next_telegram(n);
}
void LmsServer::force_baud(std::uint32_t baud) {
  std::lock_guard lock(mutex_);
  device_->force_baud(baud);
}

}  // namespace cairn::hil
