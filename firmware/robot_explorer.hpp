// A robot's side of exploration (issue 15 items 1 and 3) over its copy of the base's global
// map (firmware/global_map.hpp): every bid period it classifies the map, computes its
// frontier bid (explore::FrontierBidder) from its global pose and hands it out for the
// `Bid` topic; an EXPLORE or GOTO task from the base (which carries a target, no path) is
// planned on the same map (explore::GridPlanner) into a global path for the Navigator,
// and replanned every period on the newer map. Off the RT thread (cairn-robot's DDS
// loop); every buffer is sized from [map] max_cells at construction. Pure: time, map and
// pose come in with each call.
#pragma once

#include <cstdint>
#include <vector>

#include "common/clock.hpp"
#include "common/messages.hpp"
#include "common/stop_reason.hpp"
#include "firmware/explore/block_marks.hpp"
#include "firmware/explore/frontier_bids.hpp"
#include "firmware/explore/grid_planner.hpp"
#include "firmware/explore/marked_plan.hpp"
#include "firmware/global_map.hpp"

namespace cairn::firmware {

struct RobotExploreConfig {
  bool enabled = false;
  Nanos bid_period = 2 * kNanosPerSecond;  // bids and replans this often
  explore::FrontierBidderConfig bidder;    // max_cells is taken from [map]
  explore::GridPlannerConfig planner;      // max_cells is taken from [map]
  explore::BlockMarksConfig blocks;       // what holds the robot, marked into its plans
};

struct RobotExploreCounters {
  std::uint64_t bids = 0, bids_no_frontier = 0, bids_failed = 0;  // failed: outside the map, in an obstacle
  std::uint64_t plans = 0, plan_failures = 0, paths_cut = 0;       // cut: longer than a TaskAssignment holds
  std::uint64_t blocked_marks = 0;  // returns that held the robot, marked into the plan's map
  std::uint64_t yields = 0;         // plans that failed only for a keep-right barrier: the robot stood
};

class RobotExplorer {
 public:
  /// Throws std::invalid_argument for a bad bidder or planner parameter.
  RobotExplorer(const RobotExploreConfig& config, std::uint16_t robot_id, std::size_t max_cells);

  /// A task from the base. EXPLORE and GOTO without a path are planned at the next
  /// step(); anything else ends the current one (the Navigator applies it as it is).
  void on_task(const msg::TaskAssignment& task);

  /// The robot's stop reason this cycle and the return limiting its protective field
  /// (robot frame): held by the field, the return is marked in the plan's map and the task
  /// replanned at the next step (explore::BlockMarks).
  void on_safety(StopReason stop, const Vec2& field_nearest, const Pose2& robot_global, Nanos now);

  struct Step {
    bool bid = false;    // `bid` holds a Bid to publish (possibly empty: "nothing left for me")
    bool route = false;  // `route` holds the current task with a planned global path (or an IDLE to stand)
  };
  /// Bids every bid period while the map has tiles; plans a new task at once and the
  /// current one again every period.
  Step step(const GlobalMap& map, const Pose2& robot_global, Nanos now, msg::Bid* bid, msg::TaskAssignment* route);

  /// The last plan failed only because a keep-right barrier closes the way (a plan without
  /// barriers succeeds): the robot stands while the other passes, which is not being stuck
  /// (cairn-robot keeps its NavMonitor's clock stopped). It replans when the barrier ends.
  bool yielding() const { return yielding_; }

  const RobotExploreCounters& counters() const { return counters_; }
  const explore::BidStats& bid_stats() const { return bidder_.stats(); }

 private:
  bool plan(const Pose2& robot_global, Nanos now, msg::TaskAssignment* route);

  RobotExploreConfig config_;
  std::uint16_t robot_id_;
  explore::FrontierBidder bidder_;
  explore::GridPlanner planner_;
  ClassGrid grid_;       // reserved to max_cells
  ClassGrid plan_grid_;  // grid_ with the block marks stamped, for one plan (reserved to max_cells)
  bool have_grid_ = false;
  std::vector<Vec2> path_;
  msg::TaskAssignment task_{};
  bool task_active_ = false, task_new_ = false;
  bool yielding_ = false;
  Nanos replan_at_ = -1;  // a barrier that made the robot yield ends (-1: none)
  Nanos next_period_ = 0;
  explore::BlockMarks marks_;
  std::uint32_t bid_seq_ = 0;
  RobotExploreCounters counters_;
};

}  // namespace cairn::firmware
