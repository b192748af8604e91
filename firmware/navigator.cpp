#include "firmware/navigator.hpp"

#include <cmath>
#include <vector>

#include "firmware/robot_config.hpp"

namespace cairn::firmware {

Navigator::Navigator(const MotionConfig& cfg) : follower_cfg_(cfg.follower) {
  if (!cfg.waypoints.empty()) follower_ = std::make_unique<PathFollower>(cfg.waypoints, follower_cfg_);
}

std::string Navigator::on_task(const msg::TaskAssignment& task, const std::optional<Pose2>& local_to_global, bool replan) {
  const bool repeat = task.task_id == task_id_ && task.kind == kind_ && task.target_x == target_x_ && task.target_y == target_y_;
  if (repeat && !replan) return {};
  const auto remember = [&] {
    task_id_ = task.task_id;
    kind_ = task.kind;
    target_x_ = task.target_x;
    target_y_ = task.target_y;
  };
  switch (task.kind) {
    case msg::TaskKind::kStop:
    case msg::TaskKind::kIdle:
      follower_.reset();
      remember();
      return {};
    case msg::TaskKind::kGoto:
    case msg::TaskKind::kExplore: {
      if (!local_to_global) return "task " + std::to_string(task.task_id) + ": no PoseCorrection yet, no global frame to follow it in";
      const unsigned n = std::min<unsigned>(task.n_path, static_cast<unsigned>(msg::kMaxPath));
      std::vector<Vec2> local;
      for (unsigned i = 0; i < n; ++i) {
        const Vec2 g(task.path_xy[2 * i], task.path_xy[2 * i + 1]);
        if (!std::isfinite(g.x()) || !std::isfinite(g.y())) return "task " + std::to_string(task.task_id) + ": non-finite waypoint";
        local.push_back(inverse_transform_point(*local_to_global, g));
      }
      const Vec2 target(task.target_x, task.target_y);
      if (!std::isfinite(target.x()) || !std::isfinite(target.y())) return "task " + std::to_string(task.task_id) + ": non-finite target";
      local.push_back(inverse_transform_point(*local_to_global, target));
      follower_ = std::make_unique<PathFollower>(std::move(local), follower_cfg_);
      remember();
      return {};
    }
  }
  return "task " + std::to_string(task.task_id) + ": unknown kind " + std::to_string(static_cast<int>(task.kind));
}

void Navigator::command(const Pose2& local_pose, double speed_now, double* v, double* w) {
  *v = *w = 0;
  if (follower_) follower_->command(local_pose, speed_now, v, w);
}

}  // namespace cairn::firmware
