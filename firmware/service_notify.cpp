#include "firmware/service_notify.hpp"

#include <systemd/sd-daemon.h>

#include "common/log.hpp"

namespace cairn::firmware {

ServiceNotifier::ServiceNotifier() {
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) interval_ = static_cast<Nanos>(usec) * 1000;
}

void ServiceNotifier::ready(const std::string& status) {
  sd_notifyf(0, "READY=1\nSTATUS=%s", status.c_str());
}

void ServiceNotifier::alive(std::uint64_t rt_cycles, Nanos now) {
  if (interval_ == 0 || now < next_ping_) return;
  next_ping_ = now + interval_ / 2;
  if (seen_cycles_ && rt_cycles == last_cycles_) {
    // The RT loop stalled: no ping, so systemd restarts the service when the interval runs out.
    ++withheld_;
    if (!stalled_) CAIRN_LOG_ERROR("robot", "RT loop stalled at cycle {}: withholding the watchdog", rt_cycles);
    stalled_ = true;
    return;
  }
  seen_cycles_ = true;
  stalled_ = false;
  last_cycles_ = rt_cycles;
  ++pings_;
  sd_notify(0, "WATCHDOG=1");
}

void ServiceNotifier::stopping() { sd_notify(0, "STOPPING=1"); }

}  // namespace cairn::firmware
