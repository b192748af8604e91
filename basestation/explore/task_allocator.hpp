// The base's exploration executive (seed §4, issue 15 item 2): greedy task allocation on
// the robots' frontier bids, with the discount by overlap of information-gain regions,
// hysteresis, task monitoring, user visit requests and the end of exploration.
// Pure and deterministic: no DDS, no clock reads; every call takes the time `now`, so a
// test or cairn-sim drives it on simulated time. The DDS edge is not part of this.
//
// The algorithm as built, and the definitions chosen, are in docs/explore-executive.md.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "basestation/explore/allocator_config.hpp"
#include "basestation/explore/igr_overlap.hpp"
#include "common/clock.hpp"
#include "common/messages.hpp"
#include "common/se2.hpp"

namespace cairn::explore {

struct AllocatorCounters {
  std::uint64_t bids_received = 0, bids_rejected = 0;
  std::uint64_t rounds = 0;
  std::uint64_t explore_assigned = 0;  // new explore tasks (a kept task is not counted)
  std::uint64_t tasks_kept = 0;        // a round chose the robot's current frontier again
  std::uint64_t switches = 0;          // a robot on an explore task was given another frontier
  std::uint64_t idles = 0;             // robots told to idle by a round
  std::uint64_t arrivals = 0;          // explore targets reached
  std::uint64_t timeouts = 0;          // tasks taken back for no progress (explore and visit)
  std::uint64_t stuck_reports = 0;     // tasks taken back at once because the robot reported itself stuck
  std::uint64_t bars_set = 0, bars_expired = 0;
  std::uint64_t link_losses = 0, tasks_released = 0;  // tasks given back by a lost link
  std::uint64_t visits_requested = 0, visits_rejected = 0, visits_arrived = 0, visits_failed = 0;
  std::uint64_t explored_reports = 0, explorations_resumed = 0;
  std::uint64_t homes_sent = 0;
  std::uint64_t attempts = 0;           // robots that came within look_radius_m of a target, or were taken back there
  std::uint64_t frontiers_given_up = 0;  // times a spot reached give_up_attempts (again after a release)
  std::uint64_t given_up_released = 0;   // given-up spots offered again with more than twice their gain
  std::uint64_t assignments_emitted = 0;
  std::uint64_t pauses = 0;              // the operator stopped exploration (set_paused)
};

/// A stretch of frontier no robot can reach, as the executive reports it at the end of
/// exploration: the robots' latest unreachable clusters (msg::UnreachableCluster), merged
/// when their rectangles overlap or touch (docs/explore.md, "Unreachable frontiers").
struct UnreachableArea {
  double x = 0, y = 0;  // the merged clusters' centroids, weighted by their cells (global, m)
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;  // the union of their rectangles
  std::uint32_t cells = 0;  // the largest merged cluster's count (two robots report the same cells)
  msg::UnreachableKind kind = msg::UnreachableKind::kDisconnected;  // too narrow if any robot found it so
  std::vector<std::uint16_t> robots;  // who reported it, ascending
};

/// "too narrow at (4.20, 1.58) m, box [4.05, 4.35] x [1.35, 1.80] m, 9 cells, robots 1 2".
std::string describe(const UnreachableArea& a);
/// The export's frontiers.json: {"frame": "global", "count": N, "dropped": D, "unreachable":
/// [{"kind": "too narrow" | "disconnected", "x", "y", "min_x", "min_y", "max_x", "max_y" (m),
/// "cells", "robots": [...]}]}, largest first.
std::string unreachable_json(const std::vector<UnreachableArea>& areas, std::uint64_t dropped);
const char* to_string(msg::UnreachableKind k);

class TaskAllocator {
 public:
  explicit TaskAllocator(AllocatorConfig config);

  /// A robot's latest bid replaces its previous one. The first bid while no round is
  /// pending schedules one at now + bid_wait. A malformed bid (too many items, a
  /// non-finite or negative value, an inverted rectangle, robot 0) is refused and counted.
  bool on_bid(const msg::Bid& bid, Nanos now);
  /// The robot's global position (the fusion's estimate), for progress and arrival.
  void on_robot_pose(std::uint16_t robot, Vec2 global, Nanos now);
  /// Link state from the DDS edge (liveliness). A lost robot gives its task back.
  void on_link(std::uint16_t robot, bool alive, Nanos now);
  /// "Robot r, visit (x, y)": r's task ends, the others are reassigned, r goes there and
  /// returns to the pool when it arrives or makes no progress. false if r's link is lost.
  bool request_visit(std::uint16_t robot, Vec2 target, Nanos now);
  /// The robot reports itself stuck on `task_id` (RobotStatus.nav_state): the task is taken
  /// back at once, as the no-progress monitor would after no_progress_timeout (an explore
  /// frontier barred for this robot, a visit failed, going home given up). Returns false
  /// (nothing done) for a task that is not the robot's current, monitored one: a report
  /// about an older task, or repeated after the take-back.
  bool on_stuck(std::uint16_t robot, std::uint32_t task_id, Nanos now);

  /// The operator stops or starts exploration (the web view). Paused: no round runs, the end
  /// of exploration is not judged, and every robot in the pool is told idle (it stops where
  /// it is); visits still go, and end idle. Resumed: a full round on the robots' latest bids
  /// at once. Repeating the current state does nothing.
  void set_paused(bool paused, Nanos now);
  bool paused() const { return paused_; }

  /// Monitoring, the pending round when due, the end of exploration; appends to *out an
  /// assignment for every robot whose task changed. Returns true on the tick on which
  /// exploration ended (once per end; a later bid with gain resumes exploration).
  bool tick(Nanos now, std::vector<msg::TaskAssignment>* out);

  bool explored() const { return explored_; }
  /// Some bid has shown a frontier (an item, with or without gain, or an unreachable
  /// cluster): until then exploration does not end (the robots' maps may be empty).
  bool frontier_seen() const { return frontier_bid_; }
  /// The unreachable frontier in the robots' latest bids, merged across robots (largest
  /// first). What the end-of-exploration report lists.
  std::vector<UnreachableArea> unreachable() const;
  /// Frontier spots given up now (give_up_attempts attempts, not released), in the order
  /// of their first attempt.
  std::vector<Vec2> given_up() const;
  /// Clusters the robots' latest bids counted but could not carry (beyond msg::kMaxUnreachable).
  std::uint64_t unreachable_dropped() const;
  const AllocatorCounters& counters() const { return counters_; }
  const AllocatorConfig& config() const { return config_; }

  /// What the executive currently holds for a robot (for tests, logs and the status line).
  struct TaskView {
    msg::TaskKind kind = msg::TaskKind::kIdle;
    std::uint32_t task_id = 0;  // 0: never told anything
    Vec2 target = Vec2::Zero();
    bool active = false;  // being monitored (explore, visit or going home)
    Rect igr;             // an explore task's information-gain region (else empty)
    double gain = 0;      // an explore task's gain, as last assigned or kept
  };
  std::optional<TaskView> task(std::uint16_t robot) const;
  /// The robot's latest bid (null: none, or used up by an arrival).
  const msg::Bid* latest_bid(std::uint16_t robot) const;

 private:
  enum class Mode { kPool, kVisit, kHome };
  struct Robot {
    bool alive = true;
    bool have_pose = false;
    Vec2 pose = Vec2::Zero();
    std::optional<msg::Bid> bid;
    bool bid_fresh = false;  // not yet used by a round
    Mode mode = Mode::kPool;
    // The latest decision for this robot (what it is, or is about to be, told).
    msg::TaskKind kind = msg::TaskKind::kIdle;
    std::uint32_t task_id = 0;
    Vec2 target = Vec2::Zero();
    Rect igr;  // of the explore task's frontier, when kind == kExplore
    bool active = false;
    double best_dist = 0;  // progress monitor
    bool attempted = false;  // this task already counted as an attempt at its target
    double task_gain = 0;    // the explore task's item gain, as last assigned or kept
    Nanos last_progress = 0;
    std::uint32_t sent_task_id = 0;
  };
  struct Bar {
    std::uint16_t robot;
    Vec2 at;
    Nanos until;
  };

  Robot& robot(std::uint16_t id);
  void schedule_round(Nanos at, bool full);
  void start_task(Robot& r, msg::TaskKind kind, Vec2 target, Nanos now);
  void monitor(Nanos now);
  void take_back(std::uint16_t id, Robot& r, Nanos now);
  void run_round(Nanos now);
  bool barred(std::uint16_t robot, double x, double y, Nanos now) const;
  bool given_up(double x, double y) const;
  bool has_gain(const msg::BidItem& it) const;
  void attempt(Robot& r);
  void release_given_up(const msg::Bid& bid);
  bool check_explored(Nanos now);
  void emit(Nanos now, std::vector<msg::TaskAssignment>* out);

  AllocatorConfig config_;
  std::map<std::uint16_t, Robot> robots_;  // ordered: rounds and emission are deterministic
  std::vector<Bar> bars_;
  struct Spot {
    Vec2 at;  // the first attempt's target
    std::uint32_t attempts = 0;
    double gain = 0;  // the task's gain at the latest attempt
  };
  std::vector<Spot> spots_;
  bool is_given_up(const Spot& s) const;  // attempted frontier spots, look_radius_m apart (grows with the tasks: base side)
  std::optional<Nanos> round_due_;
  bool full_round_ = false;  // every pool robot takes part, not only unassigned / new-bid ones
  bool explored_ = false;
  bool paused_ = false;
  // Exploration ends only after some bid has shown a frontier (an item, with or without
  // gain, or an unreachable cluster): at start-up the robots' first bids can be empty because
  // their maps hold no clear cell yet (every cell still near p = 0.5), which is not an
  // explored world.
  bool frontier_bid_ = false;
  std::uint32_t next_task_id_ = 1, next_seq_ = 1;
  AllocatorCounters counters_;
};

}  // namespace cairn::explore
