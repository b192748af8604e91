#include "firmware/executive/safety.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

const char* latch_cause_text(LatchCause c) {
  switch (c) {
    case LatchCause::kNone: return "none";
    case LatchCause::kEstop: return "e-stop pressed";
    case LatchCause::kEstopInputLost: return "e-stop input lost";
    case LatchCause::kCanStalled: return "CAN thread stalled";
    case LatchCause::kRemoteStop: return "remote e-stop";
  }
  return "unknown";
}

namespace {
bool stale(Nanos last, Nanos now, Nanos timeout) { return timeout > 0 && (last < 0 || now - last > timeout); }
double ramp(double current, double target, double max_step) {
  return current + std::clamp(target - current, -max_step, max_step);
}
}  // namespace

void SafetySupervisor::latch(LatchCause c) {
  if (!latched_) cause_ = c;
  latched_ = true;
}

StopReason SafetySupervisor::evaluate(const SafetyInputs& in, double dt, double* v, double* w) {
  // The latch first: what sets it, then a reset request (accepted only when every cause is gone).
  const bool power_stale = stale(in.last_power, in.now, limits_.power_timeout);
  const bool estop_pressed = !power_stale && in.estop;
  const bool can_stalled = in.last_can_pass >= 0 && in.now - in.last_can_pass > limits_.feedback_timeout;
  if (estop_pressed) latch(LatchCause::kEstop);
  if (power_stale && in.last_power >= 0) latch(LatchCause::kEstopInputLost);  // heard once, then lost
  if (can_stalled) latch(LatchCause::kCanStalled);
  if (in.remote_stop) latch(LatchCause::kRemoteStop);
  reset_accepted_ = false;
  if (in.reset && latched_) {
    if (!power_stale && !estop_pressed && !can_stalled && !in.remote_stop) {
      latched_ = false;
      cause_ = LatchCause::kNone;
      reset_accepted_ = true;
      ++resets_accepted_;
    } else {
      ++resets_refused_;
    }
  }
  const bool feedback_stale = can_stalled || (in.drives_enabled && stale(in.last_feedback, in.now, limits_.feedback_timeout));

  StopReason r = StopReason::kNone;
  if (estop_pressed) r = StopReason::kEstop;
  else if (power_stale) r = StopReason::kPowerLost;
  else if (feedback_stale) r = StopReason::kFeedbackStale;
  else if (latched_) r = StopReason::kResetRequired;
  else if (!in.drives_enabled) r = StopReason::kDrivesNotReady;
  else if (stale(in.last_scan, in.now, limits_.laser_timeout)) r = StopReason::kLaserLost;
  else if (stale(in.last_link, in.now, limits_.link_timeout)) r = StopReason::kLinkLost;
  else if (stale(in.last_command, in.now, limits_.command_timeout)) r = StopReason::kCommandStale;
  double tv = std::isfinite(in.v) ? std::clamp(in.v, -limits_.max_v, limits_.max_v) : 0.0;
  double tw = std::isfinite(in.w) ? std::clamp(in.w, -limits_.max_w, limits_.max_w) : 0.0;
  if (r == StopReason::kNone) {
    const double fwd = std::max(0.0, in.field_forward_max_v);  // NaN fails the comparisons below: blocked
    if (tv > 0 && !(fwd > 0)) {
      r = StopReason::kProtectiveField;  // blocked ahead
    } else if (v_ > 0 && !(v_ <= in.field_brake_max_v)) {
      r = StopReason::kProtectiveField;  // braking from now would not stop in time: stop now
    } else if (tv > fwd) {
      tw *= fwd / tv;  // the same curvature, slower
      tv = fwd;
    }
    if (tv < 0 && std::isfinite(in.field_reverse_max_v)) tv = std::max(tv, -std::max(0.0, in.field_reverse_max_v));
  }
  if (r != StopReason::kNone && reason_ == StopReason::kNone) ++stops_;
  reason_ = r;
  if (r != StopReason::kNone) {
    v_ = w_ = 0;  // a stop is immediate, not ramped
  } else {
    v_ = ramp(v_, tv, limits_.max_acc * dt);
    w_ = ramp(w_, tw, limits_.max_alpha * dt);
  }
  *v = v_;
  *w = w_;
  return r;
}

}  // namespace cairn::firmware
