#include "basestation/explore/task_allocator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace cairn::explore {

namespace {

bool finite(double v) { return std::isfinite(v); }

// Every coordinate a bid carries lies within this of the origin (as a visit's target): a
// finite but absurd one (1e300) would merge every area and overflow the drawing's pixels.
constexpr double kMaxCoordinateM = 10'000;
bool place(double v) { return std::isfinite(v) && std::abs(v) <= kMaxCoordinateM; }

bool well_formed(const msg::Bid& b) {
  if (b.robot_id == 0 || b.n_items > msg::kMaxBids) return false;
  for (std::size_t k = 0; k < b.n_items; ++k) {
    const msg::BidItem& it = b.items[k];
    if (!place(it.x) || !place(it.y) || !finite(it.gain) || !finite(it.cost)) return false;
    if (!place(it.igr_min_x) || !place(it.igr_min_y) || !place(it.igr_max_x) || !place(it.igr_max_y)) return false;
    if (it.gain < 0 || it.cost < 0 || it.igr_min_x > it.igr_max_x || it.igr_min_y > it.igr_max_y) return false;
  }
  if (b.n_unreachable > msg::kMaxUnreachable) return false;
  for (std::size_t k = 0; k < b.n_unreachable; ++k) {
    const msg::UnreachableCluster& u = b.unreachable[k];
    if (!place(u.x) || !place(u.y) || !place(u.min_x) || !place(u.min_y) || !place(u.max_x) || !place(u.max_y)) return false;
    if (u.cells == 0 || !msg::valid(u.kind) || u.min_x > u.max_x || u.min_y > u.max_y) return false;
    // The centroid of cell centres lies inside the rectangle of their edges.
    if (u.x < u.min_x || u.x > u.max_x || u.y < u.min_y || u.y > u.max_y) return false;
  }
  return true;
}

bool touch(const UnreachableArea& a, const UnreachableArea& b) {
  return a.min_x <= b.max_x && b.min_x <= a.max_x && a.min_y <= b.max_y && b.min_y <= a.max_y;
}

// b into a: rectangles united, centroids weighted by cells (the weight of a merged area is
// the sum of its members', kept in *wa), robots united.
void merge_into(UnreachableArea* a, double* wa, const UnreachableArea& b, double wb) {
  a->x = (a->x * *wa + b.x * wb) / (*wa + wb);
  a->y = (a->y * *wa + b.y * wb) / (*wa + wb);
  *wa += wb;
  a->min_x = std::min(a->min_x, b.min_x), a->min_y = std::min(a->min_y, b.min_y);
  a->max_x = std::max(a->max_x, b.max_x), a->max_y = std::max(a->max_y, b.max_y);
  a->cells = std::max(a->cells, b.cells);
  if (b.kind == msg::UnreachableKind::kTooNarrow) a->kind = msg::UnreachableKind::kTooNarrow;
  for (const std::uint16_t r : b.robots)
    if (std::find(a->robots.begin(), a->robots.end(), r) == a->robots.end()) a->robots.push_back(r);
  std::sort(a->robots.begin(), a->robots.end());
}

}  // namespace

const char* to_string(msg::UnreachableKind k) {
  switch (k) {
    case msg::UnreachableKind::kTooNarrow: return "too narrow";
    case msg::UnreachableKind::kDisconnected: return "disconnected";
  }
  return "?";
}

std::string describe(const UnreachableArea& a) {
  std::string robots;
  for (const std::uint16_t r : a.robots) robots += (robots.empty() ? "" : " ") + std::to_string(r);
  char line[256];
  std::snprintf(line, sizeof line, "%s at (%.2f, %.2f) m, box [%.2f, %.2f] x [%.2f, %.2f] m, %u cell%s, robot%s %s",
                to_string(a.kind), a.x, a.y, a.min_x, a.max_x, a.min_y, a.max_y, static_cast<unsigned>(a.cells),
                a.cells == 1 ? "" : "s", a.robots.size() == 1 ? "" : "s", robots.c_str());
  return line;
}

std::string unreachable_json(const std::vector<UnreachableArea>& areas, std::uint64_t dropped) {
  std::string out = "{\"frame\": \"global\", \"count\": " + std::to_string(areas.size()) +
                    ", \"dropped\": " + std::to_string(dropped) + ", \"unreachable\": [";
  for (std::size_t k = 0; k < areas.size(); ++k) {
    const UnreachableArea& a = areas[k];
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "%s\n  {\"kind\": \"%s\", \"x\": %.3f, \"y\": %.3f, \"min_x\": %.3f, \"min_y\": %.3f, "
                  "\"max_x\": %.3f, \"max_y\": %.3f, \"cells\": %u, \"robots\": [",
                  k == 0 ? "" : ",", to_string(a.kind), a.x, a.y, a.min_x, a.min_y, a.max_x, a.max_y,
                  static_cast<unsigned>(a.cells));
    out += buf;
    for (std::size_t r = 0; r < a.robots.size(); ++r) out += (r == 0 ? "" : ", ") + std::to_string(a.robots[r]);
    out += "]}";
  }
  out += areas.empty() ? "]}\n" : "\n]}\n";
  return out;
}

std::vector<UnreachableArea> TaskAllocator::unreachable() const {
  std::vector<UnreachableArea> areas;
  std::vector<double> weight;
  for (const auto& [id, r] : robots_) {
    if (!r.bid) continue;
    for (std::size_t k = 0; k < r.bid->n_unreachable; ++k) {
      const msg::UnreachableCluster& u = r.bid->unreachable[k];
      areas.push_back({u.x, u.y, u.min_x, u.min_y, u.max_x, u.max_y, u.cells, u.kind, {id}});
      weight.push_back(static_cast<double>(u.cells));
    }
  }
  // Merge until no two touch (a merged rectangle may reach a third): at most
  // robots × kMaxUnreachable areas, so the quadratic passes are small.
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < areas.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < areas.size() && !merged; ++j) {
        if (!touch(areas[i], areas[j])) continue;
        merge_into(&areas[i], &weight[i], areas[j], weight[j]);
        areas.erase(areas.begin() + static_cast<std::ptrdiff_t>(j));
        weight.erase(weight.begin() + static_cast<std::ptrdiff_t>(j));
        merged = true;
      }
  }
  std::stable_sort(areas.begin(), areas.end(), [](const UnreachableArea& a, const UnreachableArea& b) {
    if (a.cells != b.cells) return a.cells > b.cells;
    if (a.x != b.x) return a.x < b.x;
    return a.y < b.y;
  });
  return areas;
}

std::uint64_t TaskAllocator::unreachable_dropped() const {
  std::uint64_t n = 0;
  for (const auto& [id, r] : robots_)
    if (r.bid) n += r.bid->unreachable_dropped;
  return n;
}

TaskAllocator::TaskAllocator(AllocatorConfig config) : config_(std::move(config)) { validate(config_); }

TaskAllocator::Robot& TaskAllocator::robot(std::uint16_t id) { return robots_[id]; }

void TaskAllocator::schedule_round(Nanos at, bool full) {
  round_due_ = round_due_ ? std::min(*round_due_, at) : at;
  full_round_ = full_round_ || full;
}

void TaskAllocator::start_task(Robot& r, msg::TaskKind kind, Vec2 target, Nanos now) {
  r.kind = kind;
  r.task_id = next_task_id_++;
  r.target = target;
  r.active = kind != msg::TaskKind::kIdle;
  r.best_dist = std::numeric_limits<double>::infinity();
  r.attempted = false;
  r.last_progress = now;  // no pose yet counts as no progress from the assignment on
}

bool TaskAllocator::on_bid(const msg::Bid& bid, Nanos now) {
  if (!well_formed(bid)) {
    ++counters_.bids_rejected;
    return false;
  }
  ++counters_.bids_received;
  Robot& r = robot(bid.robot_id);
  r.bid = bid;
  r.bid_fresh = true;
  release_given_up(bid);
  if (!round_due_) round_due_ = now + config_.bid_wait;  // later bids join this round
  frontier_bid_ = frontier_bid_ || bid.n_items > 0 || bid.n_unreachable > 0 || bid.unreachable_dropped > 0;
  if (explored_) {
    const bool gain = std::any_of(bid.items.begin(), bid.items.begin() + bid.n_items,
                                  [&](const msg::BidItem& it) { return has_gain(it); });
    if (gain) {  // the map changed (a door opened, a robot joined): explore again
      explored_ = false;
      ++counters_.explorations_resumed;
      for (auto& [id, other] : robots_) {
        if (other.mode == Mode::kHome) {
          other.mode = Mode::kPool;
          other.active = false;
        }
      }
    }
  }
  return true;
}

void TaskAllocator::on_robot_pose(std::uint16_t id, Vec2 global, Nanos now) {
  if (id == 0 || !finite(global.x()) || !finite(global.y())) return;
  Robot& r = robot(id);
  r.have_pose = true;
  r.pose = global;
  if (!r.active) return;
  const double dist = (global - r.target).norm();
  if (dist <= config_.look_radius_m && r.mode == Mode::kPool && r.kind == msg::TaskKind::kExplore) attempt(r);
  if (dist < r.best_dist - config_.progress_step_m) {
    r.best_dist = dist;
    r.last_progress = now;
  }
}

void TaskAllocator::on_link(std::uint16_t id, bool alive, Nanos now) {
  if (id == 0) return;
  Robot& r = robot(id);
  if (alive == r.alive) return;
  r.alive = alive;
  if (!alive) {
    ++counters_.link_losses;
    if (r.active && r.mode == Mode::kPool && r.kind == msg::TaskKind::kExplore) {
      ++counters_.tasks_released;
      schedule_round(now, true);  // its frontier is free: the others may take it
    }
    if (r.active && r.mode == Mode::kVisit) ++counters_.visits_failed;
    r.active = false;
    r.mode = Mode::kPool;
    r.bid.reset();  // computed before the loss; it bids again when it is back
    r.bid_fresh = false;
    return;
  }
  // Back: whatever it was doing may have been given to another robot. Stop it; it is
  // assigned again from its next bid.
  start_task(r, msg::TaskKind::kIdle, Vec2::Zero(), now);
}

bool TaskAllocator::request_visit(std::uint16_t id, Vec2 target, Nanos now) {
  if (id == 0 || !finite(target.x()) || !finite(target.y()) || !robot(id).alive) {
    ++counters_.visits_rejected;
    return false;
  }
  Robot& r = robot(id);
  if (r.active && r.mode == Mode::kPool && r.kind == msg::TaskKind::kExplore) schedule_round(now, true);  // cover for it
  r.mode = Mode::kVisit;
  start_task(r, msg::TaskKind::kGoto, target, now);
  ++counters_.visits_requested;
  return true;
}

bool TaskAllocator::barred(std::uint16_t id, double x, double y, Nanos now) const {
  return std::any_of(bars_.begin(), bars_.end(), [&](const Bar& b) {
    return b.robot == id && now < b.until && (b.at - Vec2(x, y)).norm() <= config_.same_frontier_m;
  });
}

bool TaskAllocator::is_given_up(const Spot& s) const {
  return config_.give_up_attempts > 0 && s.attempts >= config_.give_up_attempts;
}

bool TaskAllocator::given_up(double x, double y) const {
  return std::any_of(spots_.begin(), spots_.end(), [&](const Spot& s) {
    return is_given_up(s) && (s.at - Vec2(x, y)).norm() <= config_.look_radius_m;
  });
}

// What keeps exploration going: an item above min_gain that is not given up.
bool TaskAllocator::has_gain(const msg::BidItem& it) const { return it.gain > config_.min_gain && !given_up(it.x, it.y); }

std::vector<Vec2> TaskAllocator::given_up() const {
  std::vector<Vec2> out;
  for (const Spot& s : spots_)
    if (is_given_up(s)) out.push_back(s.at);
  return out;
}

// One attempt per task at the spot of its target: the nearest spot within look_radius_m,
// or a new one.
void TaskAllocator::attempt(Robot& r) {
  if (r.attempted) return;
  r.attempted = true;
  ++counters_.attempts;
  Spot* spot = nullptr;
  double best = config_.look_radius_m;
  for (Spot& s : spots_) {
    const double d = (s.at - r.target).norm();
    if (d <= best) best = d, spot = &s;
  }
  if (spot == nullptr) {
    spots_.push_back({r.target, 0});
    spot = &spots_.back();
  }
  spot->gain = r.task_gain;
  if (++spot->attempts == config_.give_up_attempts) ++counters_.frontiers_given_up;
}

// Not forever: a given-up spot that a bid offers again with more than twice the gain it had
// at its last attempt has changed (a door opened, a robot moved away): its attempts start
// over.
void TaskAllocator::release_given_up(const msg::Bid& bid) {
  for (Spot& s : spots_) {
    if (!is_given_up(s)) continue;
    for (std::size_t k = 0; k < bid.n_items; ++k) {
      const msg::BidItem& it = bid.items[k];
      if ((s.at - Vec2(it.x, it.y)).norm() <= config_.look_radius_m && it.gain > 2.0 * s.gain) {
        s.attempts = 0;
        ++counters_.given_up_released;
        break;
      }
    }
  }
}

void TaskAllocator::monitor(Nanos now) {
  const auto expired = std::remove_if(bars_.begin(), bars_.end(), [&](const Bar& b) { return now >= b.until; });
  counters_.bars_expired += static_cast<std::uint64_t>(bars_.end() - expired);
  bars_.erase(expired, bars_.end());

  for (auto& [id, r] : robots_) {
    if (!r.alive || !r.active) continue;
    const bool arrived = r.have_pose && (r.pose - r.target).norm() <= config_.arrival_radius_m;
    if (arrived) {
      r.active = false;
      if (r.mode == Mode::kPool) ++counters_.arrivals;
      if (r.mode == Mode::kVisit) ++counters_.visits_arrived;
      if (r.mode != Mode::kHome) {
        // Back in the pool, assigned from its next bid: the latest one was computed short
        // of the target and still offers the frontier it is now standing on.
        r.mode = Mode::kPool;
        r.bid.reset();
        r.bid_fresh = false;
      }
      continue;
    }
    if (now - r.last_progress < config_.no_progress_timeout) continue;
    ++counters_.timeouts;
    take_back(id, r, now);
  }
}

bool TaskAllocator::on_stuck(std::uint16_t id, std::uint32_t task_id, Nanos now) {
  const auto it = robots_.find(id);
  if (it == robots_.end()) return false;
  Robot& r = it->second;
  if (!r.alive || !r.active || task_id == 0 || task_id != r.task_id) return false;
  ++counters_.stuck_reports;
  take_back(id, r, now);
  return true;
}

void TaskAllocator::take_back(std::uint16_t id, Robot& r, Nanos now) {
  r.active = false;
  switch (r.mode) {
    case Mode::kPool:  // take it back, bar the frontier for this robot, reassign everyone
      if (r.kind == msg::TaskKind::kExplore) attempt(r);
      bars_.push_back({id, r.target, now + config_.bar_duration});
      ++counters_.bars_set;
      schedule_round(now, true);
      break;
    case Mode::kVisit:  // the visit failed: back to the pool with its latest bid
      ++counters_.visits_failed;
      r.mode = Mode::kPool;
      schedule_round(now, false);
      break;
    case Mode::kHome:
      start_task(r, msg::TaskKind::kIdle, Vec2::Zero(), now);
      break;
  }
}

void TaskAllocator::run_round(Nanos now) {
  ++counters_.rounds;
  struct Candidate {
    std::uint16_t robot;
    const msg::BidItem* item;
    bool hysteresis;
  };
  std::vector<std::uint16_t> unassigned;
  std::vector<Rect> assigned;  // IGRs of the tasks assigned so far (R in the seed)
  std::vector<Candidate> candidates;
  for (auto& [id, r] : robots_) {
    if (!r.alive || r.mode != Mode::kPool) continue;
    const bool on_explore = r.active && r.kind == msg::TaskKind::kExplore;
    const bool takes_part = r.bid && (full_round_ || !r.active || r.bid_fresh);
    if (!takes_part) {
      if (on_explore) assigned.push_back(r.igr);  // continuing tasks count as assigned
      continue;
    }
    unassigned.push_back(id);
    for (std::size_t k = 0; k < r.bid->n_items; ++k) {
      const msg::BidItem& it = r.bid->items[k];
      if (barred(id, it.x, it.y, now) || given_up(it.x, it.y)) continue;
      candidates.push_back({id, &it, on_explore && contains(r.igr, it.x, it.y)});
    }
  }

  std::map<std::uint16_t, const msg::BidItem*> chosen;
  while (!unassigned.empty()) {
    const Candidate* best = nullptr;
    double best_u = 0;
    for (const Candidate& c : candidates) {
      if (std::find(unassigned.begin(), unassigned.end(), c.robot) == unassigned.end()) continue;
      const double d = config_.coordinated ? overlap_fraction(igr_of(*c.item), assigned) : 0.0;
      const double gain = (1.0 - d) * c.item->gain;
      if (!(gain > config_.min_gain)) continue;  // the threshold is on the discounted gain, before hysteresis
      // Hysteresis divides by a ratio < 1: it raises the gain of the robot's own region,
      // so a competing frontier must beat it by the margin before the robot switches.
      const double u = (c.hysteresis ? gain / config_.hysteresis_ratio : gain) - config_.cells_per_metre * c.item->cost;
      if (best == nullptr || u > best_u) {  // strict: ties go to the lower robot id, then the earlier item
        best = &c;
        best_u = u;
      }
    }
    if (best == nullptr) break;
    chosen[best->robot] = best->item;
    assigned.push_back(igr_of(*best->item));
    unassigned.erase(std::find(unassigned.begin(), unassigned.end(), best->robot));
  }

  for (auto& [id, r] : robots_) {
    if (!r.alive || r.mode != Mode::kPool || !r.bid || !(full_round_ || !r.active || r.bid_fresh)) continue;
    r.bid_fresh = false;
    const bool on_explore = r.active && r.kind == msg::TaskKind::kExplore;
    const auto it = chosen.find(id);
    if (it == chosen.end()) {
      if (r.kind != msg::TaskKind::kIdle || r.task_id == 0 || r.active) {
        start_task(r, msg::TaskKind::kIdle, Vec2::Zero(), now);
        ++counters_.idles;
      }
      continue;
    }
    const msg::BidItem& item = *it->second;
    if (on_explore && (Vec2(item.x, item.y) - r.target).norm() <= config_.same_frontier_m) {
      r.igr = igr_of(item);  // same frontier, fresher region; progress monitor untouched
      r.task_gain = item.gain;
      ++counters_.tasks_kept;
      continue;
    }
    if (on_explore) ++counters_.switches;
    start_task(r, msg::TaskKind::kExplore, Vec2(item.x, item.y), now);
    r.igr = igr_of(item);
    r.task_gain = item.gain;
    ++counters_.explore_assigned;
  }
  round_due_.reset();
  full_round_ = false;
}

bool TaskAllocator::check_explored(Nanos now) {
  if (explored_ || round_due_) return false;
  bool any = false;
  for (const auto& [id, r] : robots_) {
    if (!r.alive) continue;
    any = true;
    if (r.active || !r.bid) return false;  // still working, or not yet reassessed since it arrived
    for (std::size_t k = 0; k < r.bid->n_items; ++k) {
      if (has_gain(r.bid->items[k])) return false;
    }
  }
  if (!any) return false;
  if (!frontier_bid_) return false;  // no bid has shown a frontier yet: the robots' maps may hold no clear cell
  explored_ = true;
  ++counters_.explored_reports;
  for (auto& [id, r] : robots_) {
    if (!r.alive) continue;
    const auto home = config_.home.find(id);
    if (home != config_.home.end()) {
      r.mode = Mode::kHome;
      start_task(r, msg::TaskKind::kGoto, home->second, now);
      ++counters_.homes_sent;
    } else if (r.kind != msg::TaskKind::kIdle || r.task_id == 0) {
      start_task(r, msg::TaskKind::kIdle, Vec2::Zero(), now);
    }
  }
  return true;
}

void TaskAllocator::emit(Nanos now, std::vector<msg::TaskAssignment>* out) {
  for (auto& [id, r] : robots_) {
    if (!r.alive || r.task_id == 0 || r.task_id == r.sent_task_id) continue;
    msg::TaskAssignment a;
    a.robot_id = id;
    a.seq = next_seq_++;
    a.task_id = r.task_id;
    a.issued = now;
    a.kind = r.kind;
    a.target_x = r.target.x();
    a.target_y = r.target.y();
    out->push_back(a);
    r.sent_task_id = r.task_id;
    ++counters_.assignments_emitted;
  }
}

void TaskAllocator::set_paused(bool paused, Nanos now) {
  if (paused == paused_) return;
  paused_ = paused;
  if (!paused) {
    schedule_round(now, true);
    return;
  }
  ++counters_.pauses;
  for (auto& [id, r] : robots_) {
    if (!r.alive || r.mode != Mode::kPool) continue;  // a visit or a way home goes on
    if (r.kind != msg::TaskKind::kIdle || r.active) start_task(r, msg::TaskKind::kIdle, Vec2::Zero(), now);
  }
}

bool TaskAllocator::tick(Nanos now, std::vector<msg::TaskAssignment>* out) {
  monitor(now);
  bool ended = false;
  if (!paused_) {  // paused: a due round waits for the resume, which runs a full one anyway
    if (round_due_ && now >= *round_due_) run_round(now);
    ended = check_explored(now);
  }
  emit(now, out);
  return ended;
}

std::optional<TaskAllocator::TaskView> TaskAllocator::task(std::uint16_t id) const {
  const auto it = robots_.find(id);
  if (it == robots_.end()) return std::nullopt;
  const Robot& r = it->second;
  const bool explore = r.kind == msg::TaskKind::kExplore;
  return TaskView{r.kind, r.task_id, r.target, r.active, explore ? r.igr : Rect{}, explore ? r.task_gain : 0.0};
}

const msg::Bid* TaskAllocator::latest_bid(std::uint16_t id) const {
  const auto it = robots_.find(id);
  return it == robots_.end() || !it->second.bid ? nullptr : &*it->second.bid;
}

}  // namespace cairn::explore
