// The LMS2xx emulator behind a serial line on simulated time, seen through the same
// serial::ByteStream the driver uses on a UART, a pty or TCP. There are no threads: the
// driver's own reads (and its sleeps on clock()) move simulated time, and the line carries
// the device's bytes one at a time at the device's baud rate, each arriving when its last
// bit would. So the driver's logic (baud search, mode switches, resynchronisation, fault
// recovery, baud-aware timestamps) runs deterministically, much faster than real time,
// and is tested to the byte time instead of with scheduling slack. The wire faults the
// pty server injects are injected here the same way.
#pragma once

#include <deque>
#include <random>
#include <string>

#include "common/clock.hpp"
#include "drivers/serial/byte_stream.hpp"
#include "hil/lms2xx/lms_device.hpp"

namespace cairn::hil {

class SimLmsLink final : public serial::ByteStream {
 public:
  SimLmsLink(LmsDeviceConfig cfg, const World* world, LmsDevice::PoseSource pose, Nanos start = kNanosPerSecond);

  /// Simulated time; sleeping on it (and waiting in read()) advances the device and the line.
  Clock& clock() { return clock_; }
  LmsDevice& device() { return device_; }
  /// Advances the device and the line to `t` (the driver is not stepped).
  void advance_to(Nanos t);

  // Faults, as LmsServer injects them on a pty.
  void unplug(bool unplugged) { unplugged_ = unplugged; }
  void power_cycle();

  // serial::ByteStream
  serial::IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) override;
  serial::IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) override;
  IoError set_baud(std::uint32_t baud) override;
  bool can_set_baud() const override { return true; }
  std::uint32_t baud() const override { return host_baud_; }
  void flush_input() override { rx_.clear(); }
  IoError reopen() override;
  std::string describe() const override { return "simulated LMS2xx line"; }

 private:
  class LinkClock final : public Clock {
   public:
    explicit LinkClock(SimLmsLink* link, Nanos start) : link_(link), now_(start) {}
    Nanos now() const override { return now_; }
    void sleep_until(Nanos deadline) override { link_->advance_to(deadline); }
    bool wait_event(const EventCount&, std::uint32_t, Nanos deadline) override {
      link_->advance_to(deadline);
      return false;
    }

   private:
    friend class SimLmsLink;
    SimLmsLink* link_;
    Nanos now_;
  };
  /// One step: the device polled at now, then the line carries bytes up to `t`.
  void step_to(Nanos t);
  Nanos byte_time() const;

  LinkClock clock_;
  LmsDevice device_;
  std::deque<std::uint8_t> rx_;  // arrived at the host, not yet read
  std::uint32_t host_baud_ = 9600;
  Nanos line_free_at_ = 0;       // when the byte on the line (if any) has fully arrived
  bool busy_ = false;
  bool unplugged_ = false;
  std::mt19937 noise_{12345};
};

}  // namespace cairn::hil
