#include "tools/sim/explore_driver.hpp"

#include "common/log.hpp"

#include <algorithm>
#include <cstdio>
#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string_view>

#include "basestation/explore/visit_check.hpp"

namespace cairn::sim {

ScheduledVisit ScheduledVisit::parse(const std::string& text) {
  const auto fail = [&](const std::string& why) {
    return std::invalid_argument("visit '" + text + "': " + why);
  };
  // Four fields split at ':', each parsed whole (from_chars: no sign wrap, no blanks, no overflow UB).
  std::array<std::string_view, 4> field;
  std::string_view rest = text;
  for (std::size_t k = 0; k < field.size(); ++k) {
    const std::size_t colon = rest.find(':');
    if ((k + 1 < field.size()) == (colon == std::string_view::npos)) {
      throw fail("expected T:ROBOT:X:Y (seconds, robot id, global metres)");
    }
    field[k] = rest.substr(0, colon);
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
  }
  const auto number = [&](std::string_view f, const char* what) {
    double v = 0;
    const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
    if (f.empty() || ec != std::errc() || end != f.data() + f.size() || !std::isfinite(v)) {
      throw fail(std::string(what) + " '" + std::string(f) + "' is not a finite number");
    }
    return v;
  };
  const double t = number(field[0], "time"), x = number(field[2], "x"), y = number(field[3], "y");
  unsigned robot = 0;
  const auto [end, ec] = std::from_chars(field[1].data(), field[1].data() + field[1].size(), robot);
  if (field[1].empty() || ec != std::errc() || end != field[1].data() + field[1].size() || robot < 1 || robot > 65535) {
    throw fail("robot id '" + std::string(field[1]) + "' must be 1..65535");
  }
  if (!(t >= 0 && t <= 1e6)) throw fail("time must be 0..1e6 s");
  const msg::VisitRequest v{static_cast<std::uint16_t>(robot), 0, 0, x, y, {}};
  if (base::check_visit(v, true) == base::VisitVerdict::kTooFar) throw fail(base::visit_verdict_text(base::VisitVerdict::kTooFar));
  return {seconds_to_nanos(t), static_cast<std::uint16_t>(robot), Vec2(x, y)};
}

ExploreDriver::ExploreDriver(const ExploreConfig& config, std::size_t max_cells)
    : config_(config),
      bidder_(explore::sized(config.bidder, max_cells)),
      planner_(explore::sized(config.planner, max_cells)),
      allocator_(config.allocator) {
  std::stable_sort(config_.visits.begin(), config_.visits.end(),
                   [](const ScheduledVisit& a, const ScheduledVisit& b) { return a.at < b.at; });
}

void ExploreDriver::take_visits(Nanos now, const std::vector<RobotView>& robots) {
  for (; next_visit_ < config_.visits.size() && config_.visits[next_visit_].at <= now; ++next_visit_) {
    const ScheduledVisit& sv = config_.visits[next_visit_];
    msg::VisitRequest v{};
    v.robot_id = sv.robot;
    v.x = sv.target.x();
    v.y = sv.target.y();
    const auto r = std::find_if(robots.begin(), robots.end(), [&](const RobotView& rv) { return rv.id == sv.robot; });
    // The map of the last bid round (at most bid_period old).
    const Cell target = base::visit_target_class(grid_.geometry, v.x, v.y, allocator_.config().arrival_radius_m,
                                                 [this](int i, int j) { return grid_.at(i, j); });
    base::VisitVerdict verdict = base::check_visit(v, r != robots.end() && r->localised, target);
    if (verdict == base::VisitVerdict::kAccepted && !allocator_.request_visit(sv.robot, sv.target, now)) {
      verdict = base::VisitVerdict::kRobotLost;
    }
    if (verdict == base::VisitVerdict::kAccepted) {
      ++counters_.visits_taken;
    } else {
      ++counters_.visits_refused;
      CAIRN_LOG_WARN("explore", "visit request for robot {} to ({:.2f}, {:.2f}) at {:.1f} s refused: {}", sv.robot, v.x, v.y,
                     nanos_to_seconds(now), base::visit_verdict_text(verdict));
    }
  }
}

void ExploreDriver::plan_for(std::size_t index, const RobotView& r, std::vector<PathOrder>* orders, bool back_off) {
  const auto task = allocator_.task(r.id);
  PathOrder& o = orders->emplace_back();
  o.index = index;
  o.back_off = back_off;
  bumps_[index] = r.bumps;
  front_bumps_[index] = r.front_bumps;
  if (!task || !msg::task_moves(task->kind) || !r.localised) return;  // stop
  ++counters_.plans;
  // What has held this robot (BlockMarks) is an obstacle in its plan only, as in cairn-robot
  // (and a plan closed by keep right alone is a yield: the robot stands until the barrier ends).
  const explore::MarkedPlan p =
      explore::plan_with_marks(planner_, marks_[index], grid_, &marked_, r.global.translation(), task->target, now_, &path_);
  const explore::PlanStatus s = p.status;
  replan_at_[index] = p.replan_at;
  if (p.yielding) {
    ++counters_.yields;
    return;
  }
  if (s != explore::PlanStatus::kOk) {
    // The robot stands; the allocator's monitor takes the task back after its timeout.
    ++counters_.plan_failures;
    return;
  }
  o.global_path = path_;
}

bool ExploreDriver::advance(Nanos now, const std::vector<RobotView>& robots, bool bid_now,
                            std::vector<PathOrder>* orders) {
  if (task_id_.size() < robots.size()) {
    task_id_.resize(robots.size(), 0);
    bumps_.resize(robots.size(), 0);
    front_bumps_.resize(robots.size(), 0);
    nav_.resize(robots.size(), firmware::NavMonitor(config_.nav_monitor));
    marks_.resize(robots.size(), explore::BlockMarks(config_.blocks));
    replan_at_.resize(robots.size(), -1);
  }
  now_ = now;
  std::vector<bool> held(robots.size(), false);  // marked what holds it: replan below
  for (std::size_t k = 0; k < robots.size(); ++k) {
    if (robots[k].localised && marks_[k].on_safety(robots[k].stop, robots[k].field_nearest, robots[k].global, now)) {
      held[k] = true;
      ++counters_.blocks_marked;
    }
  }
  for (const RobotView& r : robots) {
    if (r.localised) allocator_.on_robot_pose(r.id, r.global.translation(), now);
  }
  // Each robot's stuck report, as its RobotStatus would carry it: taken back at once.
  for (std::size_t k = 0; k < robots.size(); ++k) {
    const auto task = allocator_.task(robots[k].id);
    // As cairn-robot: a task whose path the robot has followed to the end is not one it is stuck on.
    const bool moving = task && task->active && msg::task_moves(task->kind) && !robots[k].path_done;
    const NavState was = nav_[k].state();
    const NavState s = nav_[k].update(task ? task->task_id : 0, moving, robots[k].stop, robots[k].local, now);
    if (s == NavState::kStuck && was != NavState::kStuck && allocator_.on_stuck(robots[k].id, task->task_id, now)) {
      ++counters_.stuck_reports;
    }
  }
  take_visits(now, robots);
  if (bid_now) {
    for (const RobotView& r : robots) {
      if (!r.localised) continue;
      msg::Bid bid;
      const explore::BidStatus s = bidder_.compute(grid_.geometry, grid_.cells.data(), r.global, &bid);
      if (s != explore::BidStatus::kOk && s != explore::BidStatus::kNoFrontier) {
        ++counters_.bids_failed;
        continue;
      }
      // An empty bid says "nothing left for me": the allocator's end of exploration needs it.
      ++(s == explore::BidStatus::kOk ? counters_.bids : counters_.bids_no_frontier);
      bid.robot_id = r.id;
      bid.seq = ++bid_seq_;
      bid.map_version = map_version_;
      (void)allocator_.on_bid(bid, now);
    }
  }
  assignments_.clear();
  if (allocator_.tick(now, &assignments_) && !explored_) {
    explored_ = true;
    explored_at_ = now;
  }
  std::vector<bool> planned(robots.size(), false);
  for (const msg::TaskAssignment& a : assignments_) {
    for (std::size_t k = 0; k < robots.size(); ++k) {
      if (robots[k].id != a.robot_id) continue;
      task_id_[k] = a.task_id;
      plan_for(k, robots[k], orders, robots[k].front_bumps != front_bumps_[k]);
      planned[k] = true;
    }
  }
  // Replan active tasks on the new map (it shows what the old path could not know), and
  // at once after a bump.
  for (std::size_t k = 0; k < robots.size(); ++k) {
    if (planned[k]) continue;
    const auto task = allocator_.task(robots[k].id);
    if (!task || !task->active || !msg::task_moves(task->kind)) continue;
    // Driven into something: back off, then a new path. Bumped while backing off: the new
    // path ends the back-off (it hit what is behind). Touching a wall while turning in place
    // is no reason to replan.
    const bool bumped = robots[k].front_bumps != front_bumps_[k];
    const bool bumped_backing = robots[k].backing_off && robots[k].bumps != bumps_[k];
    const bool barrier_ended = replan_at_[k] >= 0 && now > replan_at_[k];
    if (!bid_now && !bumped && !bumped_backing && !held[k] && !barrier_ended) continue;
    if (bumped || bumped_backing) ++counters_.replans_after_bump;
    plan_for(k, robots[k], orders, bumped);
  }
  if (bid_now) {
    std::vector<Vec2> targets;
    for (const RobotView& r : robots) {
      const auto task = allocator_.task(r.id);
      if (task && task->active && task->kind == msg::TaskKind::kExplore) targets.push_back(task->target);
    }
    bool distinct = false;
    for (std::size_t a = 0; a < targets.size() && !distinct; ++a)
      for (std::size_t b = a + 1; b < targets.size() && !distinct; ++b)
        distinct = (targets[a] - targets[b]).norm() > config_.allocator.same_frontier_m;
    if (distinct) ++counters_.periods_on_distinct_frontiers;
  }
  return explored_;
}

}  // namespace cairn::sim
