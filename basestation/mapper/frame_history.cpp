#include "basestation/mapper/frame_history.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cairn::mapper {

FrameHistory::FrameHistory(std::size_t capacity) : capacity_(capacity) {
  if (capacity_ == 0) throw std::invalid_argument("FrameHistory: capacity must be positive");
}

bool FrameHistory::record(Nanos t, const Pose2& c) {
  if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.theta)) return false;
  while (!samples_.empty() && samples_.back().t > t) samples_.pop_back();  // the clock went back
  if (!samples_.empty()) {
    const Pose2& last = samples_.back().local_to_global;
    const bool same = std::hypot(c.x - last.x, c.y - last.y) < kMinShiftM &&
                      std::abs(normalize_angle(c.theta - last.theta)) < kMinTurnRad;
    if (same) return true;
    if (samples_.back().t == t) {
      samples_.back().local_to_global = c;
      return true;
    }
  }
  if (samples_.size() == capacity_) {
    samples_.pop_front();
    ++dropped_;
  }
  samples_.push_back({t, c});
  return true;
}

std::optional<Pose2> FrameHistory::at(Nanos t) const {
  if (samples_.empty() || t < samples_.front().t) return std::nullopt;
  if (t >= samples_.back().t) return samples_.back().local_to_global;
  // The first sample later than t; the one before it is at or before t.
  const auto hi = std::upper_bound(samples_.begin(), samples_.end(), t, [](Nanos v, const Sample& s) { return v < s.t; });
  const auto lo = std::prev(hi);
  const double f = static_cast<double>(t - lo->t) / static_cast<double>(hi->t - lo->t);
  const Pose2& a = lo->local_to_global;
  const Pose2& b = hi->local_to_global;
  return Pose2{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), normalize_angle(a.theta + f * normalize_angle(b.theta - a.theta))};
}

}  // namespace cairn::mapper
