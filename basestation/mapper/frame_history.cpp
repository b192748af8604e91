#include "basestation/mapper/frame_history.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cairn::mapper {

FrameHistory::FrameHistory(std::size_t capacity) : capacity_(capacity) {
  if (capacity_ == 0) throw std::invalid_argument("FrameHistory: capacity must be positive");
}

bool FrameHistory::record(Nanos t, const Pose2& c, std::uint32_t segment, Nanos segment_from) {
  if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.theta)) return false;
  while (!samples_.empty() && samples_.back().t > t) samples_.pop_back();  // the clock went back
  Nanos from = std::min(segment_from, t);
  if (!samples_.empty()) {
    Sample& last = samples_.back();
    if (last.segment == segment) {
      const bool same = std::hypot(c.x - last.local_to_global.x, c.y - last.local_to_global.y) < kMinShiftM &&
                        std::abs(normalize_angle(c.theta - last.local_to_global.theta)) < kMinTurnRad;
      if (same) return true;
      if (last.t == t) {
        last.local_to_global = c;
        return true;
      }
      from = last.from;
    } else {
      if (last.t == t) samples_.pop_back();  // a restart at the same instant: the new frame wins
      if (!samples_.empty()) from = std::max(from, samples_.back().t + 1);  // after the old frame's last
    }
  }
  if (samples_.size() == capacity_) {
    samples_.pop_front();
    ++dropped_;
  }
  samples_.push_back({t, c, segment, from});
  return true;
}

std::optional<Pose2> FrameHistory::at(Nanos t) const {
  if (samples_.empty() || t < samples_.front().t) return std::nullopt;
  if (t >= samples_.back().t) return samples_.back().local_to_global;
  // The first sample later than t; the one before it is at or before t.
  const auto hi = std::upper_bound(samples_.begin(), samples_.end(), t, [](Nanos v, const Sample& s) { return v < s.t; });
  const auto lo = std::prev(hi);
  if (lo->segment != hi->segment) return t >= hi->from ? hi->local_to_global : lo->local_to_global;
  const double f = static_cast<double>(t - lo->t) / static_cast<double>(hi->t - lo->t);
  const Pose2& a = lo->local_to_global;
  const Pose2& b = hi->local_to_global;
  return Pose2{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), normalize_angle(a.theta + f * normalize_angle(b.theta - a.theta))};
}

}  // namespace cairn::mapper
