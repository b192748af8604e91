// cairn-sim's exploration mode (issue 15 items 3 and 4, a first slice; docs/explore.md,
// "Exploration in cairn-sim"): every bid period each robot computes its frontier bid
// (FrontierBidder) on the base's current classified map from the fusion's estimate of its
// global pose; the bids go to the base's TaskAllocator; each assignment is planned on the
// same map (GridPlanner) and handed back as a global path for the robot to follow.
// Simplifications, documented: the robots read the mapper's classified grid directly (no
// map messages), and bids and assignments do not cross the simulated link (no delay, no
// loss). Deterministic: no clock, no threads, robot order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "basestation/explore/task_allocator.hpp"
#include "common/occupancy_grid.hpp"
#include "firmware/executive/path_follower.hpp"
#include "firmware/explore/block_marks.hpp"
#include "firmware/nav_monitor.hpp"
#include "firmware/explore/frontier_bids.hpp"
#include "firmware/explore/grid_planner.hpp"
#include "firmware/explore/marked_plan.hpp"

namespace cairn::sim {

/// "Robot r, visit (x, y)" at a simulated time, as an operator's VisitRequest: "T:ROBOT:X:Y"
/// (seconds from start, robot id, global metres), e.g. "30:2:17.5:5". Throws
/// std::invalid_argument with the reason.
struct ScheduledVisit {
  Nanos at = 0;
  std::uint16_t robot = 0;
  Vec2 target = Vec2::Zero();
  static ScheduledVisit parse(const std::string& text);
};

struct ExploreConfig {
  Nanos bid_period = 2 * kNanosPerSecond;  // bids (and replans of active tasks) this often
  explore::FrontierBidderConfig bidder;    // max_cells is set from the map
  explore::GridPlannerConfig planner;      // max_cells is set from the map
  explore::AllocatorConfig allocator;
  /// The robots' path follower in exploration (replaces FleetSimConfig::follower): a short
  /// lookahead (0.36 m at cruise, down to 0.2 m while slow) and an early turn in place, so
  /// corners of the planned path in doors are not cut (the scripted tours' 0.6 m lookahead
  /// clipped door frames).
  firmware::FollowerConfig follower{
      .speed = 0.6, .turn_in_place_rad = 0.5, .lookahead_time_s = 0.6, .lookahead_min = 0.2, .lookahead_max = 0.6};
  /// After a bump the robot first backs straight off for this long at this speed, then
  /// follows its replanned path (a stand-in for the missing protective field and recovery:
  /// pushing on against a door frame slips the wheels and corrupts odometry).
  Nanos back_off = 1500 * kNanosPerMilli;
  double back_off_speed = 0.15;  // m/s
  /// Operator visit requests, passed through the base's checks (basestation/explore/
  /// visit_check.hpp) to the allocator when due, as cairn-base does with the DDS topic.
  std::vector<ScheduledVisit> visits;
  /// Each robot's stuck report (firmware/nav_monitor.hpp), as cairn-robot sends it in
  /// RobotStatus: a stuck robot's task is taken back at once (TaskAllocator::on_stuck).
  firmware::NavMonitorConfig nav_monitor;
  /// What holds a robot is marked into its own plans (explore::BlockMarks), as cairn-robot does.
  explore::BlockMarksConfig blocks;
};

struct ExploreCounters {
  std::uint64_t bids = 0, bids_no_frontier = 0, bids_failed = 0;  // failed: robot outside the map / in an obstacle
  std::uint64_t plans = 0, plan_failures = 0, replans_after_bump = 0;  // after a front bump (backs off first) or one while backing off
  /// Bid periods in which at least two robots held explore tasks on different frontiers
  /// (targets farther apart than the allocator's same_frontier_m): the coordination seen.
  std::uint64_t periods_on_distinct_frontiers = 0;
  std::uint64_t visits_taken = 0, visits_refused = 0;  // scheduled visits the base's checks passed / refused
  std::uint64_t stuck_reports = 0;  // robots that reported themselves stuck (each report once per episode)
  std::uint64_t blocks_marked = 0;  // returns that held a robot, marked (or renewed) into its plans
  std::uint64_t yields = 0;         // plans that failed only for a keep-right barrier: the robot stood
};

class ExploreDriver {
 public:
  /// What the driver needs of a robot this step (robots in id order).
  struct RobotView {
    std::uint16_t id = 0;
    bool localised = false;  // the fusion has a correction for it
    Pose2 global;            // local ⊕ correction
    std::uint64_t bumps = 0;        // steps blocked by the world (hil::DiffRobot::bumps)
    std::uint64_t front_bumps = 0;  // those driving forward: back off, then replan
    bool backing_off = false;       // a bump now ends the back-off (the replan's new path)
    StopReason stop = StopReason::kNone;  // the robot's safety state (the stuck report's input)
    Vec2 local = Vec2::Zero();            // its local position (progress, for the stuck report)
    bool path_done = true;                // it has followed its path to the end (arrived: not stuck)
    Vec2 field_nearest = Vec2::Zero();    // the return limiting its protective field (robot frame)
  };
  /// A new path for robot `index` (global frame; empty: stop).
  struct PathOrder {
    std::size_t index = 0;
    std::vector<Vec2> global_path;
    bool back_off = false;  // back off first (ExploreConfig::back_off), the robot bumped
  };

  ExploreDriver(const ExploreConfig& config, std::size_t max_cells);

  /// Called every few simulated ms (FleetSim calls it at its sample period). `map` is
  /// called for the base's classified grid at most once per bid period. Appends path orders
  /// to *orders. Returns true once exploration has ended (the allocator reported explored).
  template <class MapFn>
  bool step(Nanos now, const std::vector<RobotView>& robots, MapFn&& map, std::vector<PathOrder>* orders) {
    const bool bid_now = now >= next_bid_;
    if (bid_now) {
      next_bid_ = now + config_.bid_period;
      grid_ = map();
      ++map_version_;
    }
    return advance(now, robots, bid_now, orders);
  }

  bool explored() const { return explored_; }
  Nanos explored_at() const { return explored_at_; }
  const ExploreCounters& counters() const { return counters_; }
  const explore::TaskAllocator& allocator() const { return allocator_; }
  const ExploreConfig& config() const { return config_; }

 private:
  bool advance(Nanos now, const std::vector<RobotView>& robots, bool bid_now, std::vector<PathOrder>* orders);
  void take_visits(Nanos now, const std::vector<RobotView>& robots);
  void plan_for(std::size_t index, const RobotView& r, std::vector<PathOrder>* orders, bool back_off = false);

  ExploreConfig config_;
  explore::FrontierBidder bidder_;
  explore::GridPlanner planner_;
  explore::TaskAllocator allocator_;
  ClassGrid grid_;
  std::uint32_t map_version_ = 0, bid_seq_ = 0;
  Nanos next_bid_ = 0;
  std::vector<std::uint32_t> task_id_;   // per robot index: the task its path is for
  std::vector<std::uint64_t> bumps_, front_bumps_;  // per robot index: bumps at the last plan
  std::vector<firmware::NavMonitor> nav_;  // per robot index: its stuck report
  std::vector<explore::BlockMarks> marks_;  // per robot index: what has held it
  std::vector<Nanos> replan_at_;             // per robot index: the barrier it yields to ends (-1: none)
  ClassGrid marked_;                         // grid_ with one robot's marks, for its plan
  Nanos now_ = 0;
  std::vector<msg::TaskAssignment> assignments_;
  std::vector<Vec2> path_;
  bool explored_ = false;
  Nanos explored_at_ = 0;
  ExploreCounters counters_;
  std::size_t next_visit_ = 0;  // config_.visits is sorted by time
};

}  // namespace cairn::sim
