// What a robot's navigation is doing: RobotStatus.nav_state on the wire. Written once here
// for the robot that sets it (firmware/nav_monitor.hpp) and the base that acts on it
// (the exploration executive takes a stuck robot's task back at once).
#pragma once

#include <cstdint>

namespace cairn {

enum class NavState : std::uint8_t {
  kIdle = 0,     // no task that moves the robot
  kMoving = 1,   // on a task, making progress
  kStopped = 2,  // on a task, held by safety (e-stop, lost link, ...): not its navigation's fault
  kStuck = 3,    // on a task, no progress for stuck_after (blocked, turning in place, no plan)
};

inline constexpr NavState kLastNavState = NavState::kStuck;

constexpr const char* nav_state_text(NavState s) {
  switch (s) {
    case NavState::kIdle: return "idle";
    case NavState::kMoving: return "moving";
    case NavState::kStopped: return "stopped";
    case NavState::kStuck: return "stuck";
  }
  return "unknown";
}

}  // namespace cairn
