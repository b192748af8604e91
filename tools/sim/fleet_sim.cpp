#include "tools/sim/fleet_sim.hpp"

#include <algorithm>
#include <barrier>
#include <thread>
#include <cmath>


namespace cairn::sim {

/// The robots' outputs on their way to the base: each message is due after the link's
/// latency, or lost. One queue in send order, so delivery order is deterministic.
struct FleetSim::Outbox : firmware::RobotOutputs {
  struct Item {
    Nanos due = 0;
    bool is_odometry = false, is_laser = false;
    msg::OdometryIncrement odometry;
    msg::FeatureObservations features;
    msg::LaserScan laser;
  };
  Nanos now = 0, latency = 0;
  double loss = 0;
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> u{0.0, 1.0};
  std::deque<Item> items;
  std::uint64_t sent = 0, lost = 0;

  bool lose() {
    ++sent;
    if (loss > 0 && u(rng) < loss) {
      ++lost;
      return true;
    }
    return false;
  }
  void odometry(const msg::OdometryIncrement& m) override {
    if (lose()) return;
    Item& i = items.emplace_back();
    i.due = now + latency;
    i.is_odometry = true;
    i.odometry = m;
  }
  void laser(const msg::LaserScan& m) override {
    if (lose()) return;
    Item& i = items.emplace_back();
    i.due = now + latency;
    i.is_laser = true;
    i.laser = m;
  }
  void features(const msg::FeatureObservations& m) override {
    if (lose()) return;
    Item& i = items.emplace_back();
    i.due = now + latency;
    i.features = m;
  }
};

FleetSim::FleetSim(const FleetSimConfig& cfg) : cfg_(cfg) {
  const hil::World world = hil::World::load(cfg.world_path);
  base::FusionConfig fc;
  for (int id = 1; id <= cfg.robots; ++id) {
    worlds_.push_back(std::make_unique<hil::World>(world));
    auto& outbox = outboxes_.emplace_back(std::make_unique<Outbox>());
    outbox->latency = cfg.link_latency;
    outbox->loss = cfg.link_loss;
    outbox->rng.seed(cfg.seed * 7919 + static_cast<std::uint64_t>(id));
    const auto start = world.start(id);
    if (!start) throw std::runtime_error("world " + cfg.world_path + " has no start pose for robot " + std::to_string(id));
    SimRobotConfig rc;
    rc.id = id;
    rc.start = *start;
    rc.route = world.route(id);
    rc.scripted = !cfg.explore;
    rc.robot = cfg.robot;
    rc.robot.robot_id = static_cast<std::uint16_t>(id);
    rc.follower = cfg.explore ? cfg.exploration.follower : cfg.follower;
    rc.seed = cfg.seed * 1000 + static_cast<std::uint64_t>(id);
    robots_.push_back(std::make_unique<SimRobot>(rc, worlds_.back().get()));
    base::RobotPrior prior;
    prior.known = true;
    prior.pose = *start;
    prior.sigma = Vec3(0.05, 0.05, 0.02);
    fc.robots[static_cast<std::uint16_t>(id)] = prior;
  }
  fc.robot_observations = cfg.robot_observations;
  fusion_ = std::make_unique<base::Fusion>(fc);
  // The grid covers the world with a margin unless configured otherwise.
  mapper::MapperConfig mc = cfg.mapper;
  if (cfg.map_fits_world) {
    const auto& b = world.bounds();
    mc.origin_x = b.xmin - 2.0;
    mc.origin_y = b.ymin - 2.0;
    mc.width_m = b.xmax - b.xmin + 4.0;
    mc.height_m = b.ymax - b.ymin + 4.0;
  }
  mapper_ = std::make_unique<mapper::Mapper>(mc);
  if (cfg.explore) explore_ = std::make_unique<ExploreDriver>(cfg.exploration, mapper_->classified().geometry.cells());
}

// Exploration: the robots' global estimates (local ⊕ the fusion's correction) to the
// driver; its paths taken into each robot's local frame by the same correction.
void FleetSim::explore_step() {
  views_.clear();
  corrections_.assign(robots_.size(), Pose2());
  for (std::size_t k = 0; k < robots_.size(); ++k) {
    const auto& r = robots_[k];
    ExploreDriver::RobotView v;
    v.id = static_cast<std::uint16_t>(r->id());
    msg::PoseCorrection c;
    if (fusion_->correction(v.id, now_, &c)) {
      v.localised = true;
      v.global = compose(c.local_to_global, r->core().local_pose());
      corrections_[k] = c.local_to_global;
    }
    v.bumps = r->bumps();
    v.front_bumps = r->front_bumps();
    v.backing_off = r->backing_off(now_);
    v.stop = r->core().stop();
    v.local = r->core().local_pose().translation();
    v.path_done = r->path_done();
    v.field_nearest = r->core().field().nearest;
    views_.push_back(v);
  }
  orders_.clear();
  if (explore_->step(now_, views_, [&] { return mapper_->classified(); }, &orders_)) explored_ = true;
  for (ExploreDriver::PathOrder& o : orders_) {
    const Pose2 to_local = inverse(corrections_[o.index]);
    for (Vec2& p : o.global_path) p = transform_point(to_local, p);
    const ExploreConfig& ec = explore_->config();
    robots_[o.index]->set_path(std::move(o.global_path), now_, o.back_off ? ec.back_off : 0, ec.back_off_speed);
  }
}

// Scored against a reference built on the first call (a fine raster for the drivable
// space: tens of ms, not every coverage record); rebuilt should the map's grid change.
tools::MapQuality FleetSim::evaluate_map() const {
  const mapper::ClassGrid& map = mapper_->classified();
  const GridGeometry& g = map.geometry;
  if (!reference_ || reference_->truth.geometry.width != g.width || reference_->truth.geometry.height != g.height ||
      reference_->truth.geometry.resolution != g.resolution || reference_->truth.geometry.origin_x != g.origin_x ||
      reference_->truth.geometry.origin_y != g.origin_y) {
    double radius = 0;
    for (const auto& r : robots_) radius = std::max(radius, r->body_radius());
    reference_ = std::make_unique<tools::Reference>(
        tools::make_reference(*worlds_.front(), g, tools::default_start(*worlds_.front()), radius));
  }
  return tools::evaluate(map, *reference_, *worlds_.front());
}

void FleetSim::record_coverage() {
  const tools::MapQuality q = evaluate_map();
  coverage_.push_back({nanos_to_seconds(now_), q.coverage, q.agreement, q.drivable_coverage});
}

FleetSim::~FleetSim() = default;

void FleetSim::deliver(Nanos now) {
  for (auto& box : outboxes_) {  // robot order: deterministic whatever the threads did
    while (!box->items.empty() && box->items.front().due <= now) {
      const Outbox::Item& i = box->items.front();
      // Results (refusals included) are counted by the fusion and end in the summary.
      if (i.is_laser) {
        // The base's central mapper: the scan placed by the fusion's estimate of the
        // robot's frame; a robot not yet localised has no place for it (counted).
        if (!map_frames_.place(*mapper_, i.laser, *fusion_)) ++map_scans_unplaced_;
      } else if (i.is_odometry) {
        (void)fusion_->on_odometry(i.odometry);
      } else {
        (void)fusion_->on_features(i.features);
        map_frames_.record(*fusion_, i.features.robot_id);  // an update: the robot's frame may move
      }
      box->items.pop_front();
    }
  }
}

// One world for all: each robot's copy of the world gets every other robot's body where
// it stands now (its laser sees them, its body collides with them). Done between steps,
// in robot order, so the result does not depend on the worker threads.
void FleetSim::share_world() {
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    for (std::size_t j = 0; j < robots_.size(); ++j) {
      if (i != j) worlds_[i]->set_robot(robots_[j]->id(), robots_[j]->truth(), robots_[j]->body_radius());
    }
  }
}

// Every map_reframe_period and at the end, as the base does: the stored scans whose
// frame at their time the fusion has moved since are re-rendered where it now puts them.
// (A re-render pass looks at every stored scan: a second's period made it a third of the
// run's CPU.)
void FleetSim::reframe_map() {
  map_frames_.record(*fusion_);
  map_frames_.rerender(*mapper_);
}

std::vector<mapper::Trajectory> FleetSim::estimated_trajectories() const {
  std::vector<mapper::Trajectory> out;
  for (const auto& r : robots_) {
    mapper::Trajectory t;
    t.robot = static_cast<std::uint16_t>(r->id());
    for (const RobotSample& x : samples_) {
      if (x.robot == r->id() && x.has_global) t.points.push_back(x.global.translation());
    }
    out.push_back(std::move(t));
  }
  return out;
}

void FleetSim::step_robots() {
  for (std::size_t i; (i = next_robot_.fetch_add(1, std::memory_order_relaxed)) < robots_.size();) {
    if (steps_ > 0) robots_[i]->physics(now_ - cfg_.physics_step, cfg_.physics_step);
    outboxes_[i]->now = now_;
    robots_[i]->tick(now_, *outboxes_[i]);
  }
}

void FleetSim::run(const std::function<void(double)>& progress) {
  const Nanos end = seconds_to_nanos(cfg_.duration_s);
  Nanos next_sample = 0, next_progress = 10 * kNanosPerSecond;
  const std::size_t workers = static_cast<std::size_t>(std::max(1, std::min<int>(cfg_.threads, cfg_.robots)));
  cfg_.threads = static_cast<int>(workers);
  // Lockstep: every worker steps its robots to now_, then the main thread (worker 0) delivers
  // and samples; the barrier's completion advances the clock.
  bool done = false;
  auto between_steps = [&]() noexcept {
    if (cfg_.shared_world) share_world();
    deliver(now_);
    if (now_ >= next_reframe_) {
      next_reframe_ += cfg_.map_reframe_period;
      reframe_map();
    }
    if (now_ >= next_sample) {
      next_sample += cfg_.sample_period;
      for (auto& r : robots_) {
        RobotSample s;
        s.t = now_;
        s.robot = r->id();
        s.truth = r->truth();
        s.local = r->local_in_world();
        const auto id = static_cast<std::uint16_t>(r->id());
        msg::PoseCorrection c;
        // The base's correction carried to now with the robot's own local motion (what the
        // robot does with a PoseCorrection).
        if (fusion_->correction(id, now_, &c)) {
          s.global = compose(c.local_to_global, r->core().local_pose());
          s.global_cov = msg::to_mat(c.global_cov);
          s.has_global = true;
        }
        samples_.push_back(s);
      }
      if (explore_) explore_step();  // the exploration layer runs at the sample period
    }
    if (cfg_.coverage_period > 0 && now_ >= next_coverage_) {
      next_coverage_ += cfg_.coverage_period;
      record_coverage();
    }
    if (progress && now_ >= next_progress) {
      next_progress += 10 * kNanosPerSecond;
      progress(nanos_to_seconds(now_));
    }
    ++steps_;
    now_ += cfg_.physics_step;
    next_robot_.store(0, std::memory_order_relaxed);  // the barrier orders it before the next step
    done = now_ > end || explored_;
  };
  std::barrier sync(static_cast<std::ptrdiff_t>(workers), between_steps);
  std::vector<std::thread> threads;
  for (std::size_t w = 1; w < workers; ++w) {
    threads.emplace_back([&] {
      while (true) {
        step_robots();
        sync.arrive_and_wait();
        if (done) break;
      }
    });
  }
  while (true) {
    step_robots();
    sync.arrive_and_wait();
    if (done) break;
  }
  for (auto& t : threads) t.join();
  reframe_map();  // the map as the base's final estimates place it
  if (cfg_.coverage_period > 0) record_coverage();
}

std::vector<msg::Landmark> FleetSim::landmarks() const {
  std::vector<msg::Landmark> out;
  fusion_->landmarks(&out);
  return out;
}

std::optional<double> FleetSim::closest_approach_m() const {
  std::optional<double> best;
  // Samples of one instant are adjacent (every robot is sampled at the same steps).
  for (std::size_t a = 0; a < samples_.size(); ++a) {
    for (std::size_t b = a + 1; b < samples_.size() && samples_[b].t == samples_[a].t; ++b) {
      const double d = (samples_[a].truth.translation() - samples_[b].truth.translation()).norm();
      if (!best || d < *best) best = d;
    }
  }
  return best;
}

FleetSummary FleetSim::summary(double wall_seconds) const {
  FleetSummary s;
  s.closest_approach_m = closest_approach_m();
  for (const auto& r : robots_) {
    RobotSummary rs;
    rs.id = r->id();
    rs.distance_m = r->odometer();
    rs.scans = r->core().counters().scans;
    rs.matched = r->core().counters().matched;
    rs.bumps = r->bumps();
    double sl = 0, sg = 0, nees_pose = 0, nees_position = 0;
    std::size_t nl = 0, ng = 0;
    for (const RobotSample& x : samples_) {
      if (x.robot != r->id()) continue;
      const double el = (x.local.translation() - x.truth.translation()).norm();
      sl += el * el;
      ++nl;
      rs.local_final_err_m = el;
      if (x.has_global) {
        const double eg = (x.global.translation() - x.truth.translation()).norm();
        sg += eg * eg;
        ++ng;
        rs.global_final_err_m = eg;
        Vec3 e = x.global.vector() - x.truth.vector();
        e.z() = normalize_angle(e.z());
        nees_pose += e.dot(x.global_cov.ldlt().solve(e));
        const Vec2 ep = e.head<2>();
        nees_position += ep.dot(x.global_cov.topLeftCorner<2, 2>().ldlt().solve(ep));
      }
    }
    if (ng) {
      rs.global_nees_pose = nees_pose / static_cast<double>(ng);
      rs.global_nees_position = nees_position / static_cast<double>(ng);
    }
    rs.local_rmse_m = nl ? std::sqrt(sl / static_cast<double>(nl)) : 0;
    rs.global_rmse_m = ng ? std::sqrt(sg / static_cast<double>(ng)) : 0;
    s.robots.push_back(rs);
  }
  s.map = evaluate_map();
  s.map_scans = mapper_->counters().scans_inserted;
  s.map_scans_unplaced = map_scans_unplaced_;
  const std::vector<Vec2> poles = worlds_.front()->poles();
  s.poles = poles.size();
  double se = 0;
  for (const msg::Landmark& l : landmarks()) {
    double best = 1e9;
    for (const Vec2& p : poles) best = std::min(best, (p - Vec2(l.x, l.y)).norm());
    if (best > 0.5) {
      ++s.landmarks_far;
    } else {
      se += best * best;
    }
    ++s.landmarks;
  }
  const std::size_t near = s.landmarks - s.landmarks_far;
  s.landmark_rmse_m = near ? std::sqrt(se / static_cast<double>(near)) : 0;
  const base::FusionCounters& fcount = fusion_->counters();
  s.robot_sightings = fcount.robot_sightings;
  s.robot_sightings_unidentified = fcount.robot_sightings_unidentified;
  s.robot_observations_used = fcount.robot_observations_used;
  s.robot_sightings_paired = fcount.robot_sightings_paired;
  if (fcount.nis_count_robot) s.sighting_nis_mean = fcount.nis_sum_robot / static_cast<double>(fcount.nis_count_robot);
  if (fcount.nis_count_landmark) s.landmark_nis_mean = fcount.nis_sum_landmark / static_cast<double>(fcount.nis_count_landmark);
  for (const auto& box : outboxes_) {
    s.messages += box->sent;
    s.messages_lost += box->lost;
  }
  s.coverage = coverage_;
  for (std::size_t k = 0; k < 4; ++k) {
    for (const CoverageSample& c : coverage_) {
      if (c.coverage >= kCoverageLevels[k]) {
        s.time_to_coverage[k] = c.t_s;
        break;
      }
    }
  }
  if (explore_) {
    ExploreSummary e;
    e.explored = explore_->explored();
    e.explored_at_s = nanos_to_seconds(explore_->explored_at());
    e.allocator = explore_->allocator().counters();
    e.driver = explore_->counters();
    e.unreachable = explore_->allocator().unreachable();
    e.unreachable_dropped = explore_->allocator().unreachable_dropped();
    s.explore = e;
  }
  s.steps = steps_;
  s.sim_seconds = nanos_to_seconds(now_);
  s.wall_seconds = wall_seconds;
  s.speed_factor = wall_seconds > 0 ? s.sim_seconds / wall_seconds : 0;
  s.steps_per_second = wall_seconds > 0 ? static_cast<double>(steps_) / wall_seconds : 0;
  return s;
}

}  // namespace cairn::sim
