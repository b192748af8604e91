// CAN frames and the port interface the CANopen master and the drive emulators use.
// Backends: SocketCAN (Linux CAN_RAW; "socketcan:can0") and a user-space bus for benches
// whose kernel has no CAN ("ucan:/run/cairn/can0.sock", see can_hub.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "common/clock.hpp"
#include "common/io_error.hpp"

namespace cairn::can {

struct Frame {
  static constexpr std::uint32_t kExtended = 0x80000000u;  // flags in `id`, as in linux/can.h
  static constexpr std::uint32_t kRemote = 0x40000000u;
  static constexpr std::uint32_t kError = 0x20000000u;
  std::uint32_t id = 0;  // 11- or 29-bit identifier | flags
  std::uint8_t len = 0;  // 0..8
  std::array<std::uint8_t, 8> data{};
  Nanos stamp = 0;       // receive time (kernel timestamp where available)
  bool own = false;      // this port sent it (loopback of our own frame)

  std::uint32_t identifier() const { return id & ((id & kExtended) ? 0x1FFFFFFFu : 0x7FFu); }
  bool is_error() const { return (id & kError) != 0; }
};

/// Error-frame classes (linux/can/error.h).
enum ErrorClass : std::uint32_t {
  kErrTxTimeout = 0x1, kErrLostArbitration = 0x2, kErrController = 0x4, kErrProtocol = 0x8,
  kErrTransceiver = 0x10, kErrNoAck = 0x20, kErrBusOff = 0x40, kErrBusError = 0x80, kErrRestarted = 0x100,
};

struct BusStats {
  std::uint64_t tx = 0, rx = 0;
  std::uint64_t tx_rejected = 0;   // ENOBUFS / EAGAIN: queue full, frame not sent
  std::uint64_t tx_timeouts = 0;   // deadline passed before the frame could be queued
  std::uint64_t rx_overflow = 0;
  std::uint64_t error_frames = 0, bus_off = 0, error_passive = 0, restarts = 0;
  std::uint64_t net_down = 0;      // ENETDOWN: interface administratively down
};

enum class SendResult : std::uint8_t { kSent, kQueueFull, kTimeout, kBusOff, kDown, kError };

class Port {
 public:
  virtual ~Port() = default;
  /// Sends one frame, trying until `deadline` (absolute, monotonic) if the queue is full.
  virtual SendResult send(const Frame& f, Nanos deadline) = 0;
  /// Receives one frame, waiting at most `timeout`; false on timeout. Error frames arrive
  /// as frames with kError set (and are also counted).
  virtual bool receive(Frame* f, Nanos timeout) = 0;
  virtual const BusStats& stats() const = 0;
  virtual bool bus_off() const = 0;
  /// Recovers from bus-off / a down interface. Called on the CAN I/O thread: nothing is
  /// allocated, the code says why it failed.
  virtual IoError restart() = 0;
  virtual std::string describe() const = 0;
  /// The caller has nothing to do on this port until `until` (monotonic): the CANopen
  /// master's throttle under a flood of frames. A real port sleeps on the monotonic clock,
  /// which its own deadlines use; a simulated bus moves its simulated time instead.
  virtual void pause(Nanos until) { MonotonicClock::instance().sleep_until(until); }
};

/// Opens "socketcan:IFACE" or "ucan:PATH"; nullptr and a clear message on failure
/// (e.g. "interface can0: this kernel has no SocketCAN support").
std::unique_ptr<Port> open_port(const std::string& uri, std::string* error);

}  // namespace cairn::can
