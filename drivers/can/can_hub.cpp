#include "drivers/can/can_hub.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <string_view>
#include <stdexcept>

#include "drivers/can/socketcan_port.hpp"

namespace cairn::can {

namespace {

enum Kind : std::uint8_t { kFrame = 0, kHello = 1, kBye = 2, kRestart = 3 };

struct Wire {
  std::uint8_t bytes[16];
};

Wire encode_wire(const Frame& f, Kind kind, std::uint16_t sender) {
  Wire w{};
  for (int i = 0; i < 4; ++i) w.bytes[i] = static_cast<std::uint8_t>(f.id >> (8 * i));
  w.bytes[4] = f.len;
  w.bytes[5] = kind;
  w.bytes[6] = static_cast<std::uint8_t>(sender & 0xFF);
  w.bytes[7] = static_cast<std::uint8_t>(sender >> 8);
  std::memcpy(w.bytes + 8, f.data.data(), 8);
  return w;
}

void decode_wire(const std::uint8_t* b, Frame* f, Kind* kind, std::uint16_t* sender) {
  f->id = static_cast<std::uint32_t>(b[0] | (b[1] << 8) | (b[2] << 16)) | (static_cast<std::uint32_t>(b[3]) << 24);
  f->len = b[4] > 8 ? 8 : b[4];
  *kind = static_cast<Kind>(b[5]);
  *sender = static_cast<std::uint16_t>(b[6] | (b[7] << 8));
  std::memcpy(f->data.data(), b + 8, 8);
}

sockaddr_un unix_address(std::string_view path, socklen_t* len) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::memcpy(a.sun_path, path.data(), std::min(path.size(), sizeof a.sun_path - 1));
  *len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + std::min(path.size(), sizeof a.sun_path - 1));
  return a;
}

std::atomic<unsigned> g_port_counter{0};

}  // namespace

// ---------------------------------------------------------------- hub

Hub::Hub(std::string path) : path_(std::move(path)) {
  ::unlink(path_.c_str());
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  socklen_t len = 0;
  const sockaddr_un a = unix_address(path_, &len);
  if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&a), len) != 0) {
    throw std::runtime_error("CAN hub: cannot bind " + path_ + ": " + std::strerror(errno));
  }
  const int big = 1 << 20;
  setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
  thread_ = std::thread([this] { run(); });
}

Hub::~Hub() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
  ::close(fd_);
  ::unlink(path_.c_str());
}

std::size_t Hub::ports() const {
  std::lock_guard l(mutex_);
  return clients_.size();
}

void Hub::send_to(const Client& c, const void* data, std::size_t n) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::memcpy(a.sun_path, c.addr.data(), c.addr.size());
  ::sendto(fd_, data, n, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&a),
           static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + c.addr.size()));
}

void Hub::send_error(const Client& c, std::uint32_t error_class) {
  Frame err;
  err.id = Frame::kError | error_class;
  err.len = 8;
  const Wire w = encode_wire(err, kFrame, 0);
  send_to(c, w.bytes, sizeof w.bytes);
}

void Hub::inject_bus_off(std::uint16_t sender, Nanos hold) {
  std::lock_guard l(mutex_);
  const Nanos until = MonotonicClock::instance().now() + hold;
  for (Client& c : clients_) {
    if (sender == 0 || c.sender == sender) {
      c.bus_off = true;
      c.hold_until = until;
      send_error(c, kErrBusOff);
    }
  }
}

void Hub::run() {
  while (running_) {
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    std::uint8_t buf[16];
    sockaddr_un from{};
    socklen_t flen = sizeof from;
    const ssize_t n = ::recvfrom(fd_, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &flen);
    if (n != 16 || flen <= offsetof(sockaddr_un, sun_path)) continue;
    const std::string addr(from.sun_path, flen - offsetof(sockaddr_un, sun_path));
    Frame f;
    Kind kind;
    std::uint16_t sender;
    decode_wire(buf, &f, &kind, &sender);
    std::lock_guard l(mutex_);
    auto it = std::find_if(clients_.begin(), clients_.end(), [&](const Client& c) { return c.addr == addr; });
    if (kind == kHello) {
      if (it == clients_.end()) clients_.push_back({addr, sender, false, f.data[0] != 0, 0});
      continue;
    }
    if (kind == kBye) {
      if (it != clients_.end()) clients_.erase(it);
      continue;
    }
    if (it == clients_.end()) continue;  // not registered
    if (kind == kRestart) {
      if (MonotonicClock::instance().now() < it->hold_until) {  // the fault persists: still bus-off
        send_error(*it, kErrBusOff);
        continue;
      }
      it->bus_off = false;
      send_error(*it, kErrRestarted);
      continue;
    }
    if (it->bus_off) continue;  // a bus-off node sends nothing
    // Deliver to everyone; the sender's copy is marked as its own (kind 4). Counted first,
    // so a receiver never sees a frame the counter does not include yet.
    forwarded_.fetch_add(1, std::memory_order_relaxed);
    for (const Client& c : clients_) {
      if (c.bus_off) continue;  // a bus-off controller is off the bus: it hears nothing either
      const bool own = c.addr == addr;
      if (own && !c.wants_own) continue;
      buf[5] = own ? 4 : kFrame;
      send_to(c, buf, sizeof buf);
    }
  }
}

// ---------------------------------------------------------------- port

std::unique_ptr<UcanPort> UcanPort::open(const std::string& path, std::uint16_t sender, bool receive_own, std::string* error) {
  std::unique_ptr<UcanPort> p(new UcanPort(path, sender, receive_own));
  if (const IoError e = p->connect_hub(); !e.ok()) {
    *error = "ucan:" + path + ": no CAN hub there (" + e.sys_text() + "); is the HIL bench running?";
    return nullptr;
  }
  return p;
}

UcanPort::~UcanPort() {
  if (fd_ >= 0) {
    const Wire w = encode_wire(Frame{}, kBye, sender_);
    ::send(fd_, w.bytes, sizeof w.bytes, MSG_DONTWAIT);
    ::close(fd_);
  }
}

IoError UcanPort::connect_hub() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  // A unique abstract address, so the hub can tell ports apart and reply. Built in a fixed
  // buffer: a restart on the CAN thread allocates nothing.
  char name[64];
  name[0] = '\0';
  const int n = std::snprintf(name + 1, sizeof name - 1, "cairn-ucan-%d-%u", static_cast<int>(getpid()), g_port_counter++);
  socklen_t len = 0, hlen = 0;
  const sockaddr_un self = unix_address(std::string_view(name, static_cast<std::size_t>(n) + 1), &len);
  const sockaddr_un hub = unix_address(path_, &hlen);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&self), len) != 0 ||
      ::connect(fd_, reinterpret_cast<const sockaddr*>(&hub), hlen) != 0) {
    const IoError e = io_error_from_errno(errno);
    ::close(fd_);
    fd_ = -1;
    return e;
  }
  const int big = 1 << 20;
  setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
  Frame hello;
  hello.data[0] = receive_own_ ? 1 : 0;
  const Wire w = encode_wire(hello, kHello, sender_);
  ::send(fd_, w.bytes, sizeof w.bytes, 0);
  bus_off_ = false;
  return {};
}

SendResult UcanPort::send(const Frame& f, Nanos deadline) {
  if (bus_off_) {
    ++stats_.tx_rejected;
    return SendResult::kBusOff;
  }
  const Wire w = encode_wire(f, kFrame, sender_);
  for (;;) {
    if (::send(fd_, w.bytes, sizeof w.bytes, MSG_DONTWAIT) == 16) {
      ++stats_.tx;
      return SendResult::kSent;
    }
    if (errno == ECONNREFUSED || errno == ENOENT || errno == ENOTCONN) return SendResult::kDown;
    if (MonotonicClock::instance().now() >= deadline) {
      ++stats_.tx_rejected;
      return SendResult::kQueueFull;
    }
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, 1);
  }
}

bool UcanPort::receive(Frame* f, Nanos timeout) {
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    const int ms = timeout_to_ms(timeout);
    if (poll(&p, 1, ms) <= 0) return false;
    std::uint8_t buf[16];
    if (::recv(fd_, buf, sizeof buf, MSG_DONTWAIT) != 16) return false;
    Kind kind;
    std::uint16_t sender;
    decode_wire(buf, f, &kind, &sender);
    f->stamp = MonotonicClock::instance().now();
    f->own = kind == 4;
    if (f->own && !receive_own_) {
      timeout = 0;  // skip our own frame, keep reading what is already there
      continue;
    }
    if (f->is_error()) {
      ++stats_.error_frames;
      if (f->id & kErrBusOff) {
        bus_off_ = true;
        ++stats_.bus_off;
      }
      if (f->id & kErrRestarted) {
        bus_off_ = false;
        ++stats_.restarts;
      }
    } else {
      ++stats_.rx;
    }
    return true;
  }
}

IoError UcanPort::restart() {
  const Wire w = encode_wire(Frame{}, kRestart, sender_);
  if (::send(fd_, w.bytes, sizeof w.bytes, 0) != 16) return connect_hub();
  return {};
}

// ---------------------------------------------------------------- URIs

std::unique_ptr<Port> open_port(const std::string& uri, std::string* error) {
  if (uri.rfind("socketcan:", 0) == 0) return SocketCanPort::open(uri.substr(10), {}, error);
  if (uri.rfind("ucan:", 0) == 0) return UcanPort::open(uri.substr(5), static_cast<std::uint16_t>(getpid() & 0xFFFF), false, error);
  *error = "'" + uri + "': expected socketcan:IFACE or ucan:PATH";
  return nullptr;
}

}  // namespace cairn::can
