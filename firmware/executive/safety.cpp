#include "firmware/executive/safety.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

const char* stop_reason_text(StopReason r) {
  switch (r) {
    case StopReason::kNone: return "none";
    case StopReason::kEstop: return "e-stop pressed";
    case StopReason::kDrivesNotReady: return "drives not operation enabled";
    case StopReason::kLinkLost: return "base-station link lost";
    case StopReason::kLaserLost: return "laser silent";
    case StopReason::kCommandStale: return "no velocity command";
    case StopReason::kPowerLost: return "power board silent";
  }
  return "unknown";
}

namespace {
bool stale(Nanos last, Nanos now, Nanos timeout) { return timeout > 0 && (last < 0 || now - last > timeout); }
double ramp(double current, double target, double max_step) {
  return current + std::clamp(target - current, -max_step, max_step);
}
}  // namespace

StopReason SafetySupervisor::evaluate(const SafetyInputs& in, double dt, double* v, double* w) {
  StopReason r = StopReason::kNone;
  if (in.estop) r = StopReason::kEstop;
  else if (stale(in.last_power, in.now, limits_.power_timeout)) r = StopReason::kPowerLost;
  else if (!in.drives_enabled) r = StopReason::kDrivesNotReady;
  else if (stale(in.last_scan, in.now, limits_.laser_timeout)) r = StopReason::kLaserLost;
  else if (stale(in.last_link, in.now, limits_.link_timeout)) r = StopReason::kLinkLost;
  else if (stale(in.last_command, in.now, limits_.command_timeout)) r = StopReason::kCommandStale;
  if (r != StopReason::kNone && reason_ == StopReason::kNone) ++stops_;
  reason_ = r;
  if (r != StopReason::kNone) {
    v_ = w_ = 0;  // a stop is immediate, not ramped
  } else {
    const double tv = std::isfinite(in.v) ? std::clamp(in.v, -limits_.max_v, limits_.max_v) : 0.0;
    const double tw = std::isfinite(in.w) ? std::clamp(in.w, -limits_.max_w, limits_.max_w) : 0.0;
    v_ = ramp(v_, tv, limits_.max_acc * dt);
    w_ = ramp(w_, tw, limits_.max_alpha * dt);
  }
  *v = v_;
  *w = w_;
  return r;
}

}  // namespace cairn::firmware
