#include "basestation/explore_node.hpp"

#include "common/nav_state.hpp"

#include <cstdio>

#include "common/dds/convert.hpp"
#include "common/log.hpp"
#include "common/nav_state.hpp"

namespace cairn::base {

ExploreNode::ExploreNode(const dds::Participant& pp, const explore::AllocatorConfig& config)
    : allocator_(config),
      bid_topic_(pp),
      task_topic_(pp),
      visit_topic_(pp),
      bid_reader_(pp, bid_topic_, dds::state_qos(1)),      // the latest bid of each robot
      task_writer_(pp, task_topic_, dds::latched_qos()),   // a robot that restarts gets its task
      visit_reader_(pp, visit_topic_, dds::state_qos(1)) {  // volatile: never an old request
}

void ExploreNode::take_visits(Nanos now, const Fusion& fusion, const mapper::Mapper* map) {
  visit_reader_.take([&](const cairn_VisitRequest& d, const dds_sample_info_t&) {
    msg::VisitRequest v;
    (void)dds::from_dds(d, &v);
    (void)request_visit(v, now, fusion, map);
  });
}

VisitVerdict ExploreNode::request_visit(const msg::VisitRequest& v, Nanos now, const Fusion& fusion,
                                        const mapper::Mapper* map) {
  msg::PoseCorrection c;
  std::optional<Cell> target;
  if (map) {
    target = visit_target_class(map->geometry(), v.x, v.y, allocator_.config().arrival_radius_m,
                                [map](int i, int j) { return map->classify(i, j); });
  }
  VisitVerdict verdict = check_visit(v, fusion.correction(v.robot_id, 0, &c), target);
  if (verdict == VisitVerdict::kAccepted && !allocator_.request_visit(v.robot_id, Vec2(v.x, v.y), now)) {
    verdict = VisitVerdict::kRobotLost;
  }
  if (verdict == VisitVerdict::kAccepted) {
    ++counters_.visits_taken;
    CAIRN_LOG_INFO("explore", "visit: robot {} to ({:.2f}, {:.2f}), asked by {}", v.robot_id, v.x, v.y,
                   v.issued_by.data());
    return verdict;
  }
  // Logged when the count reaches a power of two: a flood cannot flood the log.
  const std::uint64_t n = ++counters_.visits_refused;
  if ((n & (n - 1)) == 0) {
    CAIRN_LOG_WARN("explore", "visit request for robot {} refused: {} ({} refused so far)", v.robot_id,
                   visit_verdict_text(verdict), n);
  }
  return verdict;
}

bool ExploreNode::poll(Nanos now, const Fusion& fusion, const Fleet& fleet, const mapper::Mapper* map) {
  // Only robots the fusion tracks (bounded by configuration), and only once the fleet has
  // heard from them.
  for (const std::uint16_t id : fusion.robots()) {
    const auto entry = fleet.robots().find(id);
    if (entry == fleet.robots().end()) continue;
    const bool alive = entry->second.presence == Presence::kAlive || entry->second.presence == Presence::kStale;
    auto it = alive_.find(id);
    if (it == alive_.end() || it->second != alive) {
      allocator_.on_link(id, alive, now);
      alive_[id] = alive;
    }
  }
  msg::PoseCorrection c;
  for (const std::uint16_t id : fusion.robots()) {
    if (fusion.correction(id, 0, &c)) allocator_.on_robot_pose(id, c.global_pose.translation(), now);
  }
  take_visits(now, fusion, map);
  bid_reader_.take([&](const cairn_Bid& d, const dds_sample_info_t&) {
    msg::Bid bid;
    if (!dds::from_dds(d, &bid)) ++counters_.bids_clamped;
    if (!fusion.correction(bid.robot_id, 0, &c)) {
      ++counters_.bids_unlocalised;
      return;
    }
    ++counters_.bids_taken;
    (void)allocator_.on_bid(bid, now);  // a malformed one is counted by the allocator
  });
  out_.clear();
  const bool completed = allocator_.tick(now, &out_);  // true once, on the tick exploration ended
  for (const msg::TaskAssignment& a : out_) {
    cairn_TaskAssignment d{};
    dds::to_dds(a, &d);
    if (task_writer_.write(d)) {
      ++counters_.assignments_written;
    } else {
      ++counters_.write_failures;
    }
  }
  if (completed) {
    CAIRN_LOG_INFO("explore", "exploration complete: no frontier with a gain above {} cells is left", allocator_.config().min_gain);
    const std::vector<explore::UnreachableArea> left = allocator_.unreachable();
    CAIRN_LOG_INFO("explore", "unreachable frontiers: {} (clusters the robots could not send: {})", left.size(),
                   allocator_.unreachable_dropped());
    for (const explore::UnreachableArea& a : left) CAIRN_LOG_INFO("explore", "unreachable: {}", explore::describe(a));
    for (const Vec2& p : allocator_.given_up())
      CAIRN_LOG_INFO("explore", "given up: the frontier at ({:.2f}, {:.2f}) m stayed after {} attempts", p.x(), p.y(),
                     allocator_.config().give_up_attempts);
  }
  return completed;
}

void ExploreNode::on_nav(std::uint16_t robot, std::uint8_t nav_state, std::uint32_t task_id, Nanos now) {
  if (nav_state != static_cast<std::uint8_t>(NavState::kStuck)) return;
  if (allocator_.on_stuck(robot, task_id, now)) {
    CAIRN_LOG_WARN("explore", "robot {} reports itself stuck on task {}: taken back, its target barred for it", robot, task_id);
  }
}

void ExploreNode::set_running(bool run, Nanos now, const char* by) {
  if (run == !allocator_.paused()) {
    CAIRN_LOG_INFO("explore", "exploration already {} (asked by {})", run ? "running" : "stopped", by);
    return;
  }
  allocator_.set_paused(!run, now);
  if (run) {
    CAIRN_LOG_INFO("explore", "exploration started again by {}", by);
  } else {
    CAIRN_LOG_INFO("explore", "exploration stopped by {}: robots told to idle, visits still go", by);
  }
}

std::string ExploreNode::summary() const {
  const auto& a = allocator_.counters();
  char line[420];
  std::snprintf(line, sizeof line,
                "explore: %s; bids %llu (unlocalised %llu, rejected %llu), rounds %llu, assigned %llu, kept %llu, "
                "idles %llu, timeouts %llu, stuck %llu, given up %llu, visits %llu (refused %llu), written %llu (failed %llu)",
                allocator_.paused()           ? "stopped by the operator"
                : allocator_.explored()       ? "explored"
                : allocator_.frontier_seen() ? "exploring"
                                             : "exploring (no bid has shown a frontier yet: the end waits for one)",
                static_cast<unsigned long long>(counters_.bids_taken),
                static_cast<unsigned long long>(counters_.bids_unlocalised),
                static_cast<unsigned long long>(a.bids_rejected), static_cast<unsigned long long>(a.rounds),
                static_cast<unsigned long long>(a.explore_assigned), static_cast<unsigned long long>(a.tasks_kept),
                static_cast<unsigned long long>(a.idles), static_cast<unsigned long long>(a.timeouts),
                static_cast<unsigned long long>(a.stuck_reports), static_cast<unsigned long long>(a.frontiers_given_up),
                static_cast<unsigned long long>(counters_.visits_taken),
                static_cast<unsigned long long>(counters_.visits_refused),
                static_cast<unsigned long long>(counters_.assignments_written),
                static_cast<unsigned long long>(counters_.write_failures));
  return line;
}

}  // namespace cairn::base
