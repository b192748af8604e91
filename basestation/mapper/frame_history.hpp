// Where a robot's local frame lay in the global frame over time, as the estimator had it.
// The robot's local frame drifts (odometry and scan matching accumulate error) and the
// fusion's landmark updates take the drift out in steps, so today's local→global is
// right for today's scans only. A stored scan is placed by the frame at its own time:
// between two recorded frames the drift the later one removed is taken to have grown
// evenly since the earlier one (linear interpolation), after the last one the last holds.
// A robot that restarts begins a new local frame (a new *segment*, its boot epoch):
// frames of two segments are never blended.
// Pure: no clock, no fusion, no DDS (docs/mapper.md, "Frames over time").
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

#include "common/clock.hpp"
#include "common/se2.hpp"

namespace cairn::mapper {

class FrameHistory {
 public:
  struct Sample {
    Nanos t = 0;  // the robot's clock: the time of the estimate the frame was computed at
    Pose2 local_to_global;
    std::uint32_t segment = 0;  // the local frame it belongs to (the robot's boot epoch)
    Nanos from = 0;             // when that local frame began (its first odometry), <= t
  };
  /// Frames that differ from the last kept one by less than this are not kept: the frame
  /// only moves at updates, and a run of equal frames would turn the even growth of drift
  /// between updates into a step at the update.
  static constexpr double kMinShiftM = 0.001, kMinTurnRad = 0.0001;

  /// `capacity` samples at most (> 0); the oldest go first (counted).
  explicit FrameHistory(std::size_t capacity);

  /// The estimator's frame at robot time `t`, of local frame `segment` which began at
  /// `segment_from`. A non-finite frame is refused (false). Within a segment, a sample at
  /// the last one's time replaces it. One older than the last drops the later ones (the
  /// robot's clock went back: the machine rebooted).
  bool record(Nanos t, const Pose2& local_to_global, std::uint32_t segment = 0, Nanos segment_from = 0);
  /// The frame at robot time `t`: interpolated between the samples around it when both
  /// are of one segment; across a restart, the earlier segment's last frame before the
  /// later one began and the later one's first from then on; the last one after them;
  /// nullopt before the first (nothing known: leave such a scan alone).
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
