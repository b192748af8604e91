#include "drivers/can/socketcan_port.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>
#include <cstring>

namespace cairn::can {

std::unique_ptr<SocketCanPort> SocketCanPort::open(const std::string& iface, const std::vector<Filter>& filters,
                                                   std::string* error) {
  if (filters.size() > kMaxFilters) {
    *error = "interface " + iface + ": " + std::to_string(filters.size()) + " filters, at most " + std::to_string(kMaxFilters);
    return nullptr;
  }
  std::unique_ptr<SocketCanPort> p(new SocketCanPort(iface, filters));
  const IoError e = p->open_socket();
  if (e.ok()) return p;
  const std::string why = std::string(io_errc_text(e.code)) + (e.sys ? std::string(" (") + e.sys_text() + ")" : "");
  if (e.code == IoErrc::kUnsupported) {
    *error = "interface " + iface + ": this kernel has no SocketCAN support (socket(PF_CAN): " + e.sys_text() +
             "); use the VM bench, or a user-space bus (ucan:PATH)";
  } else if (e.code == IoErrc::kNotFound) {
    *error = "interface " + iface + ": no such CAN interface (" + e.sys_text() + ")";
  } else {
    *error = "interface " + iface + ": cannot open: " + why;
  }
  return nullptr;
}

SocketCanPort::~SocketCanPort() {
  if (fd_ >= 0) ::close(fd_);
}

IoError SocketCanPort::open_socket() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC | SOCK_NONBLOCK, CAN_RAW);
  if (fd_ < 0) {
    return errno == EAFNOSUPPORT || errno == EPROTONOSUPPORT ? IoError{IoErrc::kUnsupported, errno} : io_error_from_errno(errno);
  }
  auto fail = [this](IoError e) {
    ::close(fd_);
    fd_ = -1;
    return e;
  };
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, iface_.c_str(), IFNAMSIZ - 1);
  if (::ioctl(fd_, SIOCGIFINDEX, &ifr) != 0) return fail({IoErrc::kNotFound, errno});
  can_filter f[kMaxFilters];  // on the stack: a restart on the CAN thread allocates nothing
  for (std::size_t i = 0; i < filters_.size(); ++i) f[i] = {filters_[i].id, filters_[i].mask};
  if (!filters_.empty()) setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, f, static_cast<socklen_t>(filters_.size() * sizeof(can_filter)));
  const can_err_mask_t err_mask = CAN_ERR_MASK;  // every error class arrives as an error frame
  setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
  const int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return fail(io_error_from_errno(errno));
  bus_off_ = false;
  return {};
}

SendResult SocketCanPort::send(const Frame& f, Nanos deadline) {
  can_frame cf{};
  cf.can_id = f.id;
  cf.len = f.len;
  std::memcpy(cf.data, f.data.data(), 8);
  for (;;) {
    const ssize_t n = ::write(fd_, &cf, sizeof cf);
    if (n == static_cast<ssize_t>(sizeof cf)) {
      ++stats_.tx;
      return SendResult::kSent;
    }
    if (errno == ENETDOWN) {
      ++stats_.net_down;
      return SendResult::kDown;
    }
    if (errno != ENOBUFS && errno != EAGAIN) return SendResult::kError;
    // TX queue full (no ACK on the bus, bus-off, or load): retry until the deadline.
    if (MonotonicClock::instance().now() >= deadline) {
      ++stats_.tx_rejected;
      return bus_off_ ? SendResult::kBusOff : SendResult::kQueueFull;
    }
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, 1);
  }
}

bool SocketCanPort::receive(Frame* f, Nanos timeout) {
  pollfd p{fd_, POLLIN, 0};
  const int ms = timeout_to_ms(timeout);
  if (poll(&p, 1, ms) <= 0) return false;
  can_frame cf{};
  iovec iov{&cf, sizeof cf};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n != static_cast<ssize_t>(sizeof cf)) {
    if (n < 0 && errno == ENETDOWN) ++stats_.net_down;
    return false;
  }
  f->id = cf.can_id;
  f->len = cf.len > 8 ? 8 : cf.len;
  std::memcpy(f->data.data(), cf.data, 8);
  f->own = (msg.msg_flags & MSG_CONFIRM) != 0;
  f->stamp = MonotonicClock::instance().now();
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      // The kernel stamps frames in CLOCK_REALTIME; move the stamp onto the monotonic clock
      // by the current offset between the two (exact unless the wall clock steps right now).
      timespec ts, real;
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      clock_gettime(CLOCK_REALTIME, &real);
      const Nanos kernel = static_cast<Nanos>(ts.tv_sec) * kNanosPerSecond + ts.tv_nsec;
      const Nanos wall = static_cast<Nanos>(real.tv_sec) * kNanosPerSecond + real.tv_nsec;
      f->stamp -= wall - kernel;
    }
  }
  if (f->is_error()) {
    ++stats_.error_frames;
    if (cf.can_id & CAN_ERR_BUSOFF) {
      bus_off_ = true;
      ++stats_.bus_off;
    }
    if ((cf.can_id & CAN_ERR_CRTL) && (cf.data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))) ++stats_.error_passive;
    if (cf.can_id & CAN_ERR_RESTARTED) {
      bus_off_ = false;
      ++stats_.restarts;
    }
  } else {
    ++stats_.rx;
  }
  return true;
}

IoError SocketCanPort::restart() {
  // Bus-off recovery itself is the kernel's (ip link ... restart-ms N); we reopen the socket
  // so a down/up interface is picked up again.
  ++stats_.restarts;
  return open_socket();
}

}  // namespace cairn::can
