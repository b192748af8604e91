// The base's exploration executive on DDS (issue 15 item 2, its edge): the robots' `Bid`s
// in, `TaskAssignment`s out, the allocator itself pure (basestation/explore/). A bid is
// taken only from a robot the fusion has localised (its global pose is what the
// allocator's progress monitor watches; an unknown id cannot grow the allocator's
// tables); others are counted. A robot the fleet reports lost gives its task back, and
// its return gives it a link again. An operator's VisitRequest (`cairn-base --visit`) is taken only for a localised robot and a finite target within reach of any
// building; the allocator then sends the robot there and covers for its frontier.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "basestation/explore/task_allocator.hpp"
#include "basestation/explore/visit_check.hpp"
#include "basestation/fleet.hpp"
#include "basestation/fusion.hpp"
#include "basestation/mapper/mapper.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

struct ExploreNodeCounters {
  std::uint64_t bids_taken = 0;
  std::uint64_t bids_unlocalised = 0;  // from a robot the fusion has no estimate of
  std::uint64_t bids_clamped = 0;      // more items than a Bid holds: cut, still used
  std::uint64_t assignments_written = 0, write_failures = 0;
  std::uint64_t visits_taken = 0, visits_refused = 0;
};



class ExploreNode {
 public:
  ExploreNode(const dds::Participant& pp, const explore::AllocatorConfig& config);
  /// Takes the visit requests and bids that arrived, tells the allocator every localised robot's global pose
  /// and every change of link, runs it and writes what it assigns. Never blocks. Returns
  /// true in the poll where exploration became complete (once per completion).
  /// `map`: the central map visit targets are checked against (none: not checked).
  bool poll(Nanos now, const Fusion& fusion, const Fleet& fleet, const mapper::Mapper* map = nullptr);
  /// A robot's RobotStatus navigation report (common/nav_state.hpp). kStuck on its
  /// current task: the allocator takes the task back at once (logged); anything else,
  /// unknown values included, is ignored.
  void on_nav(std::uint16_t robot, std::uint8_t nav_state, std::uint32_t task_id, Nanos now);
  /// An operator's visit request, checked (visit_check.hpp) and given to the allocator:
  /// what a VisitRequest from DDS reaches, and what the web view calls in process.
  /// Counted and logged either way; returns the verdict.
  VisitVerdict request_visit(const msg::VisitRequest& v, Nanos now, const Fusion& fusion, const mapper::Mapper* map);
  /// The operator stops (false) or starts (true) exploration: TaskAllocator::set_paused, logged.
  void set_running(bool run, Nanos now, const char* by);
  /// One line for the console.
  std::string summary() const;
  const explore::TaskAllocator& allocator() const { return allocator_; }
  const ExploreNodeCounters& counters() const { return counters_; }
  /// Bids dropped for a robot_id other than their writer's partition's (a robot posing as another).
  std::uint64_t foreign_samples() const { return bid_reader_.foreign_samples(); }

 private:
  explore::TaskAllocator allocator_;
  dds::Topic<cairn_Bid> bid_topic_;
  dds::Topic<cairn_TaskAssignment> task_topic_;
  dds::Topic<cairn_VisitRequest> visit_topic_;
  dds::Reader<cairn_Bid> bid_reader_;
  dds::Writer<cairn_TaskAssignment> task_writer_;
  dds::Reader<cairn_VisitRequest> visit_reader_;
  std::map<std::uint16_t, bool> alive_;  // the link state last told to the allocator
  std::vector<msg::TaskAssignment> out_;
  ExploreNodeCounters counters_;

  void take_visits(Nanos now, const Fusion& fusion, const mapper::Mapper* map);
};

}  // namespace cairn::base
