// Where a robot's local frame lay in the global frame over time, as the estimator had it.
// The robot's local frame drifts (odometry and scan matching accumulate error) and the
// fusion's landmark updates take the drift out in steps, so today's local→global is
// right for today's scans only. A stored scan is placed by the frame at its own time:
// between two recorded frames the drift the later one removed is taken to have grown
// evenly since the earlier one (linear interpolation), after the last one the last holds.
// Pure: no clock, no fusion, no DDS (docs/mapper.md, "Frames over time").
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

#include "common/se2.hpp"
#include "common/clock.hpp"

namespace cairn::mapper {

class FrameHistory {
 public:
  struct Sample {
    Nanos t = 0;  // the robot's clock: the time of the estimate the frame was computed at
    Pose2 local_to_global;
  };
  /// Frames that differ from the last kept one by less than this are not kept: the frame
  /// only moves at updates, and a run of equal frames would turn the even growth of drift
  /// between updates into a step at the update.
  static constexpr double kMinShiftM = 0.001, kMinTurnRad = 0.0001;

  /// `capacity` samples at most (> 0); the oldest go first (counted).
  explicit FrameHistory(std::size_t capacity);

  /// The estimator's frame at robot time `t`. A non-finite frame is refused (false). A
  /// sample at the last one's time replaces it; one older than the last drops the later
  /// ones (the robot's clock went back: it rebooted).
  bool record(Nanos t, const Pose2& local_to_global);
  /// The frame at robot time `t`: interpolated between the samples around it, the last
  /// one after them; nullopt before the first (nothing known: leave such a scan alone).
  std::optional<Pose2> at(Nanos t) const;

  /// The oldest frame kept; nullopt when none.
  std::optional<Pose2> first() const {
    return samples_.empty() ? std::nullopt : std::optional<Pose2>(samples_.front().local_to_global);
  }
  std::size_t size() const { return samples_.size(); }
  std::uint64_t dropped() const { return dropped_; }  // oldest samples dropped when full

 private:
  std::size_t capacity_;
  std::deque<Sample> samples_;
  std::uint64_t dropped_ = 0;
};

}  // namespace cairn::mapper
