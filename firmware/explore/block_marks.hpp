// What holds a robot on its path, remembered for its planner (issue 15 item 3: "stops the
// robot ... then replans"): held by its protective field for `replan_after`, the return
// that limits the field is marked, in the global frame, as an obstacle disc of `radius_m`
// for `memory` (at most kMarks, the oldest replaced; a return already marked is renewed,
// not marked again), and the caller replans with the marks stamped into its classified
// map. cairn-robot's RobotExplorer and cairn-sim's exploration driver both use it. Pure,
// fixed size.
//
// Keep right: for `keep_right_memory` a mark on something the map does not hold (another
// robot, a person: the mapper keeps robots out of the map) also closes the robot's left of
// the return, a barrier `keep_right_m` long from the return across the robot's heading at
// the time, so the replanned path passes what holds it on the right. Two robots that meet
// head-on are each held by the other; with a disc alone both replanned round the same side
// (the shorter way, the same for both in a corridor), met again, and took 15-30 s to pass
// in the office world's corridor. Keeping right, they pass on opposite sides. A return on
// the map (an obstacle cell within radius_m plus a cell of it: a wall, a door jamb) gets
// the disc alone: the building does not move out of the way, and a barrier from a jamb at
// the robot's front right closed its own way. A robot whose right is closed (a wall) finds
// no path and yields, standing while the other passes (the caller tells a yield from a
// dead end by planning again without barriers, stamp(..., false)); after
// keep_right_memory it may pass on the left.
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
  double keep_right_m = 1.0;  // 0: no barrier. About a robot's diameter plus its radius
  Nanos keep_right_memory = 5 * kNanosPerSecond;
};

class BlockMarks {
 public:
  static constexpr std::size_t kMarks = 8;
  explicit BlockMarks(const BlockMarksConfig& config) : cfg_(config) {}

  /// The robot's stop reason this cycle and the return limiting its field (robot frame).
  /// True when a return was marked or renewed: the caller should replan now.
  bool on_safety(StopReason stop, const Vec2& field_nearest, const Pose2& robot_global, Nanos now);
  /// Marks the live marks' cells as obstacles, and with `barriers` the live keep-right
  /// barriers of marks not on the map (judged on `grid` as given). Returns the barriers
  /// stamped (or that would have been, without `barriers`).
  std::size_t stamp(ClassGrid* grid, Nanos now, bool barriers = true) const;
  /// When the first live keep-right barrier ends (-1: none is live).
  Nanos next_barrier_end(Nanos now) const;
  std::uint64_t marked() const { return marked_; }

 private:
  struct Mark {
    Vec2 at{0, 0};
    Vec2 left{0, 0};           // unit, the robot's left when it was held (global frame)
    Nanos until = -1;          // forgotten after (-1: empty)
    Nanos barrier_until = -1;  // its keep-right barrier forgotten after
  };
  BlockMarksConfig cfg_;
  std::array<Mark, kMarks> marks_{};
  std::size_t next_ = 0;
  Nanos blocked_since_ = -1, last_ = -1;
  std::uint64_t marked_ = 0;
};

}  // namespace cairn::explore
