#include "firmware/nav_monitor.hpp"

namespace cairn::firmware {

NavState NavMonitor::update(std::uint32_t task_id, bool moving, StopReason stop, const Vec2& position, Nanos now) {
  const NavState before = state_;
  if (task_id != task_id_) since_ = -1;  // a new task starts afresh
  task_id_ = task_id;
  if (task_id == 0 || !moving) {
    state_ = NavState::kIdle;
    since_ = -1;
    return state_;
  }
  if (stop != StopReason::kNone && stop != StopReason::kProtectiveField) {
    state_ = NavState::kStopped;
    since_ = -1;  // the clock starts again when safety lets it move
    return state_;
  }
  if (since_ < 0 || (position - anchor_).norm() >= cfg_.progress_m) {
    anchor_ = position;
    since_ = now;
  }
  state_ = now - since_ >= cfg_.stuck_after ? NavState::kStuck : NavState::kMoving;
  if (state_ == NavState::kStuck && before != NavState::kStuck) ++stuck_;
  return state_;
}

}  // namespace cairn::firmware
