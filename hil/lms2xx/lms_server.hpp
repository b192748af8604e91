// Serves an emulated LMS2xx over a pty pair (the host opens tty:/dev/pts/N), a TCP port on
// 127.0.0.1 (like a serial device server) or a real serial port (a UART of the VM bench,
// wired to the host's UART by a null-modem cable). A thread paces the device's output at
// its baud rate (8N1: 10 bits per byte) and, on a pty, reads the host side's termios: when
// the host's baud differs from the device's, bytes in both directions turn to garbage,
// as on a real line. On a UART the port follows the device's baud, as the scanner's own
// UART does; the far end's rate is the host's business. Faults are injected on command.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "hil/lms2xx/lms_device.hpp"

namespace cairn::hil {

class LmsServer {
 public:
  enum class Link { kPty, kTcp, kUart };
  /// Creates the link; the device is powered on when start() is called. `tcp_port` is for
  /// kTcp, `uart` (a device path such as /dev/ttyS2) for kUart.
  LmsServer(Link link, LmsDeviceConfig cfg, const World* world, LmsDevice::PoseSource pose, int tcp_port = 0,
            const std::string& uart = {});
  ~LmsServer();
  LmsServer(const LmsServer&) = delete;
  LmsServer& operator=(const LmsServer&) = delete;

  void start();
  void stop();
  /// The URI a driver opens: tty:/dev/pts/N or tcp:127.0.0.1:PORT (kUart: the emulator's
  /// own end, tty:PATH; the host opens the other end of the cable).
  std::string uri() const { return uri_; }

  // Faults.
  void unplug(bool unplugged);   // silence in both directions (cable pulled)
  void power_cycle();            // reboot: back to 9600, idle, power-on telegram after boot time
  void inject_garbage(std::size_t n);
  void corrupt_next_crc();
  void drop_bytes(std::size_t n);
  void force_baud(std::uint32_t baud);

  /// Runs f with the device locked (inspect counters, sent scans).
  template <typename F>
  auto with_device(F&& f) {
    std::lock_guard lock(mutex_);
    return f(*device_);
  }
  std::uint32_t host_baud() const { return host_baud_.load(); }
  /// kUart: the port's baud could not be set to the device's (the last refused rate, 0: none).
  std::uint32_t uart_baud_refused() const { return uart_refused_.load(); }

 private:
  void run();
  void serve_once(Nanos now);
  int accept_client();

  Link link_;
  std::string uri_;
  int fd_ = -1;         // pty master, or the connected TCP client
  int listen_fd_ = -1;  // TCP only
  std::unique_ptr<LmsDevice> device_;
  std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> unplugged_{false};
  std::atomic<std::uint32_t> host_baud_{0};
  std::atomic<std::uint32_t> uart_refused_{0};
  std::uint32_t uart_baud_ = 0;  // the rate the UART is set to
  Nanos tx_credit_time_ = 0;
  bool was_busy_ = false;
  std::mt19937 noise_{7};
};

}  // namespace cairn::hil
