// What holds a robot on its path, remembered for its planner (issue 15 item 3: "stops the
// robot ... then replans"): held by its protective field for `replan_after`, the return
// that limits the field is marked, in the global frame, as an obstacle disc of `radius_m`
// for `memory` (at most kMarks, the oldest replaced; a return already marked is renewed,
// not marked again), and the caller replans with the marks stamped into its classified
// map. cairn-robot's RobotExplorer and cairn-sim's exploration driver both use it. Pure,
// fixed size.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "common/clock.hpp"
#include "common/occupancy_grid.hpp"
#include "common/se2.hpp"
#include "common/stop_reason.hpp"

namespace cairn::explore {

struct BlockMarksConfig {
  Nanos replan_after = 1 * kNanosPerSecond;
  Nanos memory = 20 * kNanosPerSecond;
  double radius_m = 0.15;
};

class BlockMarks {
 public:
  static constexpr std::size_t kMarks = 8;
  explicit BlockMarks(const BlockMarksConfig& config) : cfg_(config) {}

  /// The robot's stop reason this cycle and the return limiting its field (robot frame).
  /// True when a return was marked or renewed: the caller should replan now.
  bool on_safety(StopReason stop, const Vec2& field_nearest, const Pose2& robot_global, Nanos now);
  /// Marks the live marks' cells as obstacles.
  void stamp(ClassGrid* grid, Nanos now) const;
  std::uint64_t marked() const { return marked_; }

 private:
  struct Mark {
    Vec2 at{0, 0};
    Nanos until = -1;  // forgotten after (-1: empty)
  };
  BlockMarksConfig cfg_;
  std::array<Mark, kMarks> marks_{};
  std::size_t next_ = 0;
  Nanos blocked_since_ = -1, last_ = -1;
  std::uint64_t marked_ = 0;
};

}  // namespace cairn::explore
