// SocketCAN (CAN_RAW): filters, error frames (bus-off, error-passive), kernel receive
// timestamps (SO_TIMESTAMPNS), ENOBUFS and ENETDOWN handled and counted.
#pragma once

#include <vector>

#include "drivers/can/can_port.hpp"

namespace cairn::can {

struct Filter {
  std::uint32_t id, mask;
};

class SocketCanPort final : public Port {
 public:
  static constexpr std::size_t kMaxFilters = 16;
  /// Nullptr and a message on failure (no such interface, no SocketCAN in this kernel,
  /// more than kMaxFilters filters).
  static std::unique_ptr<SocketCanPort> open(const std::string& iface, const std::vector<Filter>& filters, std::string* error);
  ~SocketCanPort() override;
  SendResult send(const Frame& f, Nanos deadline) override;
  bool receive(Frame* f, Nanos timeout) override;
  const BusStats& stats() const override { return stats_; }
  bool bus_off() const override { return bus_off_; }
  IoError restart() override;
  std::string describe() const override { return "socketcan:" + iface_; }

 private:
  SocketCanPort(std::string iface, std::vector<Filter> filters) : iface_(std::move(iface)), filters_(std::move(filters)) {}
  IoError open_socket();  // allocates nothing (a restart on the CAN thread calls it)
  std::string iface_;
  std::vector<Filter> filters_;
  int fd_ = -1;
  bool bus_off_ = false;
  BusStats stats_;
};

}  // namespace cairn::can
