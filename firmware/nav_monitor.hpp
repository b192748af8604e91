// The robot's own progress monitor (issue 15 item 3: "a stuck robot reports it"): on a task
// that moves it, the robot is stuck when it has not got `progress_m` away from where it
// was for `stuck_after`: blocked by its protective field, turning in place, rocking on the
// spot, or standing because it cannot plan. Safety stops other than the protective field
// (e-stop, lost link or laser, ...) pause the clock: they are not the navigation's doing.
// A new task starts afresh. Pure: pose, stop reason and time come with every call.
#pragma once

#include <cstdint>

#include "common/clock.hpp"
#include "common/nav_state.hpp"
#include "common/se2.hpp"
#include "common/stop_reason.hpp"

namespace cairn::firmware {

struct NavMonitorConfig {
  Nanos stuck_after = 5 * kNanosPerSecond;
  double progress_m = 0.3;
};

class NavMonitor {
 public:
  explicit NavMonitor(const NavMonitorConfig& config) : cfg_(config) {}
  /// `task_id`: the base's current task (0: none); `moving`: it is one that moves the robot
  /// and has not been reported done. Returns the state to report.
  NavState update(std::uint32_t task_id, bool moving, StopReason stop, const Vec2& position, Nanos now);
  NavState state() const { return state_; }
  std::uint32_t task_id() const { return task_id_; }
  std::uint64_t stuck_reports() const { return stuck_; }  // times the state became kStuck

 private:
  NavMonitorConfig cfg_;
  NavState state_ = NavState::kIdle;
  std::uint32_t task_id_ = 0;
  Vec2 anchor_{0, 0};
  Nanos since_ = -1;  // when the robot was last at the anchor (-1: no clock running)
  std::uint64_t stuck_ = 0;
};

}  // namespace cairn::firmware
