#include "firmware/robot_explorer.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

RobotExplorer::RobotExplorer(const RobotExploreConfig& config, std::uint16_t robot_id, std::size_t max_cells)
    : config_(config),
      robot_id_(robot_id),
      bidder_(explore::sized(config.bidder, max_cells)),
      planner_(explore::sized(config.planner, max_cells)),
      marks_(config.blocks) {
  grid_.cells.reserve(max_cells);
  plan_grid_.cells.reserve(max_cells);
  path_.reserve(1024);
}

void RobotExplorer::on_task(const msg::TaskAssignment& task) {
  task_ = task;
  task_active_ = msg::task_moves(task.kind) && task.n_path == 0;  // a path from the base is followed as given
  task_new_ = task_active_;
  yielding_ = false;
  replan_at_ = -1;
}

void RobotExplorer::on_safety(StopReason stop, const Vec2& field_nearest, const Pose2& robot_global, Nanos now) {
  if (!marks_.on_safety(stop, field_nearest, robot_global, now)) return;
  counters_.blocked_marks = marks_.marked();
  if (task_active_) task_new_ = true;  // replan now, round it
}

bool RobotExplorer::plan(const Pose2& robot_global, Nanos now, msg::TaskAssignment* route) {
  *route = task_;
  route->n_path = 0;
  ++counters_.plans;
  // The marks go into a copy: stamped into grid_ they would pile up between two periods'
  // classifications (an expired mark or an old barrier still closing the way).
  explore::PlanStatus s = explore::PlanStatus::kBadMap;
  yielding_ = false;
  replan_at_ = -1;
  if (have_grid_) {
    const explore::MarkedPlan p = explore::plan_with_marks(planner_, marks_, grid_, &plan_grid_, robot_global.translation(),
                                                           Vec2(task_.target_x, task_.target_y), now, &path_);
    s = p.status;
    if (p.yielding) {
      yielding_ = true;
      replan_at_ = p.replan_at;
      ++counters_.yields;
      route->kind = msg::TaskKind::kIdle;  // stand while the other passes
      return false;
    }
  }
  if (s != explore::PlanStatus::kOk) {
    // Stand: the base's monitor takes the task back when no progress follows.
    ++counters_.plan_failures;
    route->kind = msg::TaskKind::kIdle;
    return false;
  }
  // The Navigator follows path_xy and then the target; the path's last point is the goal
  // the planner reached (an unreachable goal cell is replaced by a reachable one near it).
  // A path longer than a task holds is cut, and its last kept point is this leg's target:
  // the next replan goes on from there.
  std::size_t n = path_.size();
  if (n > msg::kMaxPath + 1) {
    ++counters_.paths_cut;
    n = msg::kMaxPath + 1;
  }
  if (n > 0) {
    route->target_x = path_[n - 1].x();
    route->target_y = path_[n - 1].y();
  }
  const std::size_t waypoints = n == 0 ? 0 : n - 1;  // the last one is the target
  route->n_path = static_cast<std::uint16_t>(waypoints);
  for (std::size_t i = 0; i < waypoints; ++i) {
    route->path_xy[2 * i] = path_[i].x();
    route->path_xy[2 * i + 1] = path_[i].y();
  }
  return true;
}

RobotExplorer::Step RobotExplorer::step(const GlobalMap& map, const Pose2& robot_global, Nanos now, msg::Bid* bid,
                                        msg::TaskAssignment* route) {
  Step out;
  const bool period = now >= next_period_;
  const bool barrier_ended = replan_at_ >= 0 && now > replan_at_;
  if (!period && !task_new_ && !barrier_ended) return out;
  if (period) {
    next_period_ = now + config_.bid_period;
    have_grid_ = map.classify(&grid_);
    if (have_grid_) {
      *bid = msg::Bid{};
      const explore::BidStatus s = bidder_.compute(grid_.geometry, grid_.cells.data(), robot_global, bid);
      if (s == explore::BidStatus::kOk || s == explore::BidStatus::kNoFrontier) {
        // An empty bid says "nothing left for me": the base's end of exploration needs it.
        ++(s == explore::BidStatus::kOk ? counters_.bids : counters_.bids_no_frontier);
        bid->robot_id = robot_id_;
        bid->seq = ++bid_seq_;
        out.bid = true;
      } else {
        ++counters_.bids_failed;
      }
    }
  }
  if (barrier_ended && !task_active_) replan_at_ = -1;
  if (task_active_ && (task_new_ || period || barrier_ended)) {
    task_new_ = false;
    (void)plan(robot_global, now, route);
    out.route = true;
  }
  return out;
}

}  // namespace cairn::firmware
