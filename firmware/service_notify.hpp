// Tells systemd how the robot service is doing (sd_notify): READY once the executive runs,
// and watchdog pings only while the real-time loop keeps cycling, so a hung RT loop gets
// the service restarted (cairn-robot.service: Type=notify, WatchdogSec). Without
// NOTIFY_SOCKET (not started by systemd) every call is a no-op.
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"

namespace cairn::firmware {

class ServiceNotifier {
 public:
  ServiceNotifier();
  bool watchdog_enabled() const { return interval_ > 0; }
  Nanos watchdog_interval() const { return interval_; }
  void ready(const std::string& status);
  /// Call often from the non-RT loop with the RT loop's cycle count; pings at half the
  /// watchdog interval, and only if the count moved since the last ping.
  void alive(std::uint64_t rt_cycles, Nanos now);
  void stopping();
  std::uint64_t pings() const { return pings_; }
  std::uint64_t withheld() const { return withheld_; }  // pings skipped because the RT loop stalled

 private:
  Nanos interval_ = 0;  // systemd's WatchdogSec, 0 when off
  Nanos next_ping_ = 0;
  std::uint64_t last_cycles_ = 0;
  bool seen_cycles_ = false, stalled_ = false;
  std::uint64_t pings_ = 0, withheld_ = 0;
};

}  // namespace cairn::firmware
