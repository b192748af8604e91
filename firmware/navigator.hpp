// The robot's non-RT motion source: follows the configured path (local frame) until
// the base station assigns a task; a GOTO task's path arrives in the global frame and
// is taken into the local frame through the latest PoseCorrection. Pure.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "common/messages.hpp"
#include "common/se2.hpp"
#include "firmware/executive/path_follower.hpp"

namespace cairn::firmware {

struct MotionConfig;

class Navigator {
 public:
  explicit Navigator(const MotionConfig& cfg);
  /// Applies a task. Returns an empty string, or why it was refused (a GOTO before
  /// any PoseCorrection has no frame to be followed in; a NaN in the path). A repeat (the
  /// topic is latched) is ignored: the same task id, kind and target; a restarted base
  /// numbers its tasks from 1 again, so the id alone is not enough. `replan` applies a
  /// new path for the current task (the robot's own planner) even so.
  std::string on_task(const msg::TaskAssignment& task, const std::optional<Pose2>& local_to_global, bool replan = false);
  /// Velocity to request now (zero when idle or done); `speed_now` is the robot's present
  /// forward speed (it sets the lookahead).
  void command(const Pose2& local_pose, double speed_now, double* v, double* w);
  bool active() const { return follower_ != nullptr && !follower_->done(); }
  /// The current task moves the robot and its path has been followed to the end.
  bool finished() const { return follower_ != nullptr && follower_->done() && msg::task_moves(kind_); }
  std::uint32_t task_id() const { return task_id_; }

 private:
  FollowerConfig follower_cfg_;
  std::unique_ptr<PathFollower> follower_;
  std::uint32_t task_id_ = 0;
  msg::TaskKind kind_ = msg::TaskKind::kIdle;
  double target_x_ = 0, target_y_ = 0;
};

}  // namespace cairn::firmware
