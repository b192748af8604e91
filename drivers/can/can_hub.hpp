// A user-space CAN bus for benches whose kernel has no CAN (these machines: no vcan).
// The hub owns a Unix datagram socket at PATH; every port ("ucan:PATH") registers with it
// and each frame sent is delivered to every other port, like a real bus and like
// SocketCAN's default local loopback; the sender gets its own copy marked `own` only if it
// asked for it (CAN_RAW_RECV_OWN_MSGS semantics). Frames keep their order. Faults: the hub
// can put a port into bus-off (its frames are dropped and it receives a bus-off error
// frame) until that port restarts.
//
// Datagram format (16 bytes, little-endian): id u32 (with the linux/can.h flag bits),
// len u8, kind u8 (0 frame, 1 hello, 2 bye, 3 restart), sender u16, data[8].
#pragma once

#include <atomic>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/can/can_port.hpp"

namespace cairn::can {

class Hub {
 public:
  explicit Hub(std::string path);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;
  const std::string& path() const { return path_; }
  std::string uri() const { return "ucan:" + path_; }

  /// Puts the port that registered with `sender` into bus-off (or every port with sender 0).
  /// For `hold` the fault persists (a shorted or open bus): restart requests are refused.
  void inject_bus_off(std::uint16_t sender, Nanos hold = 0);
  std::uint64_t frames_forwarded() const { return forwarded_.load(); }
  std::size_t ports() const;

 private:
  struct Client {
    std::string addr;  // abstract socket address (with the leading NUL)
    std::uint16_t sender = 0;
    bool bus_off = false;
    bool wants_own = false;  // CAN_RAW_RECV_OWN_MSGS
    Nanos hold_until = 0;
  };
  void run();
  void send_to(const Client& c, const void* data, std::size_t n);
  void send_error(const Client& c, std::uint32_t error_class);
  std::string path_;
  int fd_ = -1;
  std::thread thread_;
  std::atomic<bool> running_{true};
  mutable std::mutex mutex_;
  std::vector<Client> clients_;
  std::atomic<std::uint64_t> forwarded_{0};
};

/// A port on a Hub's bus.
class UcanPort final : public Port {
 public:
  /// `sender` identifies this port to the hub (for fault injection); `receive_own` as CAN_RAW_RECV_OWN_MSGS.
  static std::unique_ptr<UcanPort> open(const std::string& path, std::uint16_t sender, bool receive_own, std::string* error);
  ~UcanPort() override;
  SendResult send(const Frame& f, Nanos deadline) override;
  bool receive(Frame* f, Nanos timeout) override;
  const BusStats& stats() const override { return stats_; }
  bool bus_off() const override { return bus_off_; }
  IoError restart() override;
  std::string describe() const override { return "ucan:" + path_; }

 private:
  UcanPort(std::string path, std::uint16_t sender, bool own) : path_(std::move(path)), sender_(sender), receive_own_(own) {}
  IoError connect_hub();  // allocates nothing (a restart on the CAN thread calls it)
  std::string path_;
  std::uint16_t sender_;
  bool receive_own_;
  int fd_ = -1;
  bool bus_off_ = false;
  BusStats stats_;
};

}  // namespace cairn::can
