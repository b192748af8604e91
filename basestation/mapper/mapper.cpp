#include "basestation/mapper/mapper.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

#include "common/config.hpp"

namespace cairn::mapper {

double logit(double p) { return std::log(p / (1.0 - p)); }

namespace {

bool finite(const Pose2& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta); }

std::int32_t milli(double l) { return static_cast<std::int32_t>(std::lround(1000.0 * l)); }

}  // namespace

void validate(const MapperConfig& c) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("mapper: " + what); };
  auto fin = [&](double v, const char* name) {
    if (!std::isfinite(v)) bad(std::string(name) + " must be finite");
  };
  fin(c.resolution_m, "resolution_m");
  fin(c.origin_x, "origin_x");
  fin(c.origin_y, "origin_y");
  fin(c.width_m, "width_m");
  fin(c.height_m, "height_m");
  fin(c.min_range_m, "min_range_m");
  fin(c.max_range_m, "max_range_m");
  fin(c.rerender_shift_m, "rerender_shift_m");
  if (c.resolution_m < 0.01 || c.resolution_m > 5.0) bad("resolution_m must be in [0.01, 5] m");
  if (c.width_m <= 0 || c.height_m <= 0) bad("width_m and height_m must be positive");
  const double cells = std::ceil(c.width_m / c.resolution_m - 1e-9) * std::ceil(c.height_m / c.resolution_m - 1e-9);
  if (cells > static_cast<double>(c.max_cells))
    bad("the grid (" + std::to_string(static_cast<long long>(cells)) + " cells) exceeds max_cells (" +
        std::to_string(c.max_cells) + "): raise max_cells or shrink width_m/height_m or coarsen resolution_m");
  if (c.min_range_m < 0 || c.max_range_m <= c.min_range_m) bad("need 0 <= min_range_m < max_range_m");
  if (c.max_range_m > 1000) bad("max_range_m must be <= 1000 m");
  auto prob = [&](double p, const char* name) {
    if (!(p > 0 && p < 1)) bad(std::string(name) + " must be in (0, 1)");
  };
  prob(c.p_hit, "p_hit");
  prob(c.p_miss, "p_miss");
  prob(c.p_min, "p_min");
  prob(c.p_max, "p_max");
  prob(c.p_o, "p_o");
  prob(c.p_c, "p_c");
  if (!(c.p_hit > 0.5)) bad("p_hit must exceed 0.5 (a hit must raise occupancy)");
  if (!(c.p_miss < 0.5)) bad("p_miss must be below 0.5 (a miss must lower occupancy)");
  if (!(c.p_min < c.p_c && c.p_c < c.p_o && c.p_o < c.p_max))
    bad("need p_min < p_c < p_o < p_max (otherwise a class can never be reached)");
  if (c.insert_every < 1) bad("insert_every must be >= 1");
  if (c.rerender_shift_m < 0) bad("rerender_shift_m must be >= 0");
  fin(c.robot_mask_radius_m, "robot_mask_radius_m");
  if (c.robot_mask_radius_m < 0 || c.robot_mask_radius_m > 5) bad("robot_mask_radius_m must be in [0, 5] m");
}

MapperConfig mapper_config_from(const ConfigSection& s) {
  MapperConfig c;
  c.resolution_m = s.number_or("resolution_m", c.resolution_m, {0.01, 5.0});
  if (s.has("origin")) {
    const auto v = s.numbers("origin", 2, 2);
    c.origin_x = v[0];
    c.origin_y = v[1];
  }
  if (s.has("size_m")) {
    const auto v = s.numbers("size_m", 2, 2);
    if (v[0] <= 0 || v[1] <= 0) s.fail("size_m", "expected [width m, height m], both positive");
    c.width_m = v[0];
    c.height_m = v[1];
  }
  c.max_cells = static_cast<std::size_t>(s.integer_or("max_cells", static_cast<std::int64_t>(c.max_cells), {1, 1LL << 32}));
  c.min_range_m = s.number_or("min_range_m", c.min_range_m, {0.0, 100.0});
  c.max_range_m = s.number_or("max_range_m", c.max_range_m, {0.1, 1000.0});
  c.p_hit = s.number_or("p_hit", c.p_hit, {0.5001, 0.9999});
  c.p_miss = s.number_or("p_miss", c.p_miss, {0.0001, 0.4999});
  c.p_min = s.number_or("p_min", c.p_min, {0.0001, 0.9999});
  c.p_max = s.number_or("p_max", c.p_max, {0.0001, 0.9999});
  c.p_o = s.number_or("p_o", c.p_o, {0.0001, 0.9999});
  c.p_c = s.number_or("p_c", c.p_c, {0.0001, 0.9999});
  c.insert_every = static_cast<int>(s.integer_or("insert_every", c.insert_every, {1, 1000}));
  c.store_bytes = static_cast<std::size_t>(s.number_or("store_mib", static_cast<double>(c.store_bytes) / (1 << 20), {0.0, 65536.0}) *
                                           (1 << 20));
  c.rerender_shift_m = s.number_or("rerender_shift_m", c.rerender_shift_m, {0.0, 100.0});
  c.robot_mask_radius_m = s.number_or("robot_mask_radius_m", c.robot_mask_radius_m, {0.0, 5.0});
  try {
    validate(c);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string(e.what()) + " (in [mapper])");
  }
  return c;
}

Mapper::Mapper(const MapperConfig& config) : config_(config) {
  validate(config_);
  geometry_.resolution = config_.resolution_m;
  geometry_.origin_x = config_.origin_x;
  geometry_.origin_y = config_.origin_y;
  geometry_.width = static_cast<int>(std::ceil(config_.width_m / config_.resolution_m - 1e-9));
  geometry_.height = static_cast<int>(std::ceil(config_.height_m / config_.resolution_m - 1e-9));
  l_hit_ = milli(logit(config_.p_hit));
  l_miss_ = milli(logit(config_.p_miss));
  l_min_ = milli(logit(config_.p_min));
  l_max_ = milli(logit(config_.p_max));
  sum_.assign(geometry_.cells(), 0);
  observed_.assign(geometry_.cells(), 0);
  mark_.assign(geometry_.cells(), 0);
}

Mapper::AddResult Mapper::add_scan_local(const msg::LaserScan& scan, const Pose2& local_to_global,
                                         std::span<const Vec2> robots) {
  return add_scan(scan, compose(local_to_global, scan.pose), robots);
}

Mapper::AddResult Mapper::add_scan(const msg::LaserScan& scan, const Pose2& sensor_pose, std::span<const Vec2> robots) {
  ++counters_.scans_received;
  if (!finite(sensor_pose) || !std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment) ||
      scan.n_beams > msg::kMaxBeams) {
    ++counters_.scans_invalid;
    return AddResult::kRejected;
  }
  int si = 0, sj = 0;
  if (!geometry_.cell_of(sensor_pose.x, sensor_pose.y, &si, &sj)) {
    ++counters_.scans_outside;
    return AddResult::kRejected;
  }
  const std::uint64_t n = seen_[scan.robot_id]++;
  if (n % static_cast<std::uint64_t>(config_.insert_every) != 0) {
    ++counters_.scans_subsampled;
    return AddResult::kSubsampled;
  }
  Stored s;
  s.info = {scan.robot_id, scan.seq, scan.stamp, scan.pose, scan.sensor_offset, sensor_pose};
  s.angle_min = scan.angle_min;
  s.angle_increment = scan.angle_increment;
  s.ranges_mm.assign(scan.ranges_mm.begin(), scan.ranges_mm.begin() + scan.n_beams);
  s.ranges_mm.shrink_to_fit();
  // Beam statistics are counted once, at insertion.
  for (std::uint16_t r : s.ranges_mm) {
    const double m = r * 1e-3;
    if (r == 0 || m >= config_.max_range_m)
      ++counters_.beams_max_range;
    else if (m < config_.min_range_m)
      ++counters_.beams_short;
  }
  mark_robot_returns(&s, sensor_pose, robots);
  render(s, sensor_pose, +1);
  ++counters_.scans_inserted;

  const std::size_t b = bytes_of(s);
  if (b > config_.store_bytes) {
    ++counters_.scans_not_stored;  // frozen in the grid at once
    return AddResult::kInserted;
  }
  while (!store_.empty() && store_bytes_ + b > config_.store_bytes) {
    store_bytes_ -= bytes_of(store_.front());
    store_.pop_front();
    ++counters_.store_dropped;
  }
  store_bytes_ += b;
  store_.push_back(std::move(s));
  return AddResult::kInserted;
}

void Mapper::mark_robot_returns(Stored* s, const Pose2& sensor_pose, std::span<const Vec2> robots) {
  const double r2 = config_.robot_mask_radius_m * config_.robot_mask_radius_m;
  if (r2 <= 0 || robots.empty()) return;
  for (std::size_t k = 0; k < s->ranges_mm.size(); ++k) {
    const double r = s->ranges_mm[k] * 1e-3;
    if (s->ranges_mm[k] == 0 || r >= config_.max_range_m || r < config_.min_range_m) continue;
    const double a = sensor_pose.theta + static_cast<double>(s->angle_min) +
                     static_cast<double>(s->angle_increment) * static_cast<double>(k);
    const Vec2 end(sensor_pose.x + r * std::cos(a), sensor_pose.y + r * std::sin(a));
    for (const Vec2& c : robots) {
      if (!c.allFinite() || (end - c).squaredNorm() > r2) continue;
      if (s->on_robot.empty()) s->on_robot.assign(s->ranges_mm.size(), false);
      s->on_robot[k] = true;
      ++counters_.beams_on_robots;
      break;
    }
  }
  s->on_robot.shrink_to_fit();
}

void Mapper::touch(int i, int j) {
  if (!changed_) {
    changed_ = Region{i, j, i, j};
    return;
  }
  changed_->i0 = std::min(changed_->i0, i);
  changed_->j0 = std::min(changed_->j0, j);
  changed_->i1 = std::max(changed_->i1, i);
  changed_->j1 = std::max(changed_->j1, j);
}

void Mapper::render(const Stored& s, const Pose2& pose, int sign) {
  if (++mark_stamp_ == 0) {  // wrapped: clear the stamps once every 2^32 scans
    std::fill(mark_.begin(), mark_.end(), 0u);
    mark_stamp_ = 1;
  }
  const double res = geometry_.resolution;
  const double gx0 = (pose.x - geometry_.origin_x) / res, gy0 = (pose.y - geometry_.origin_y) / res;
  const int i0 = static_cast<int>(std::floor(gx0)), j0 = static_cast<int>(std::floor(gy0));
  scratch_hits_.clear();
  scratch_misses_.clear();
  bool clipped = false;

  // Pass 1: hit cells (a hit wins over a miss of the same scan).
  const std::size_t n = s.ranges_mm.size();
  for (std::size_t k = 0; k < n; ++k) {
    const double r = s.ranges_mm[k] * 1e-3;
    if (s.ranges_mm[k] == 0 || r >= config_.max_range_m || r < config_.min_range_m) continue;
    if (!s.on_robot.empty() && s.on_robot[k]) continue;  // a robot's body: no obstacle (pass 2 skips its cell too)
    const double a = pose.theta + static_cast<double>(s.angle_min) + static_cast<double>(s.angle_increment) * static_cast<double>(k);
    int i = 0, j = 0;
    if (!geometry_.cell_of(pose.x + r * std::cos(a), pose.y + r * std::sin(a), &i, &j)) continue;
    const std::size_t idx = geometry_.index(i, j);
    if (mark_[idx] == mark_stamp_) continue;
    mark_[idx] = mark_stamp_;
    scratch_hits_.push_back(idx);
  }
  // Pass 2: the cells each beam crosses before its endpoint's cell (4-connected DDA,
  // Amanatides & Woo), up to max_range_m for beams without a usable return.
  for (std::size_t k = 0; k < n; ++k) {
    double r = s.ranges_mm[k] * 1e-3;
    const bool has_hit = s.ranges_mm[k] != 0 && r < config_.max_range_m;
    if (has_hit && r < config_.min_range_m) continue;
    if (!has_hit) r = config_.max_range_m;
    const double a = pose.theta + static_cast<double>(s.angle_min) + static_cast<double>(s.angle_increment) * static_cast<double>(k);
    const double dx = std::cos(a), dy = std::sin(a);
    const double gx1 = gx0 + r * dx / res, gy1 = gy0 + r * dy / res;
    const int i1 = static_cast<int>(std::floor(gx1)), j1 = static_cast<int>(std::floor(gy1));
    const int step_i = i1 > i0 ? 1 : -1, step_j = j1 > j0 ? 1 : -1;
    int left_i = std::abs(i1 - i0), left_j = std::abs(j1 - j0);
    // Ray parameter (in cells travelled along the beam) at the next x / y cell border.
    const double inf = std::numeric_limits<double>::infinity();
    const double tdx = dx != 0 ? 1.0 / std::abs(dx) : inf, tdy = dy != 0 ? 1.0 / std::abs(dy) : inf;
    double tx = dx > 0 ? (std::floor(gx0) + 1 - gx0) * tdx : dx < 0 ? (gx0 - std::floor(gx0)) * tdx : inf;
    double ty = dy > 0 ? (std::floor(gy0) + 1 - gy0) * tdy : dy < 0 ? (gy0 - std::floor(gy0)) * tdy : inf;
    int i = i0, j = j0;
    const int total = left_i + left_j;
    // Cells before the last one are misses; the last is the hit's cell, or for a
    // max-range beam also a miss.
    for (int step = 0; step <= total; ++step) {
      const bool last = step == total;
      if (!geometry_.contains(i, j)) {
        clipped = true;
        break;  // the grid is convex: a beam that left it does not come back
      }
      if (!(last && has_hit)) {
        const std::size_t idx = geometry_.index(i, j);
        if (mark_[idx] != mark_stamp_) {
          mark_[idx] = mark_stamp_;
          scratch_misses_.push_back(idx);
        }
      }
      if (last) break;
      if (left_j == 0 || (left_i > 0 && tx < ty)) {
        i += step_i;
        tx += tdx;
        --left_i;
      } else {
        j += step_j;
        ty += tdy;
        --left_j;
      }
    }
  }
  if (clipped && sign > 0) ++counters_.beams_clipped;
  const std::int32_t hit = sign * l_hit_, miss = sign * l_miss_;
  const auto obs = static_cast<std::uint32_t>(sign);  // +1, or -1 wrapping (unsigned arithmetic)
  auto apply = [&](std::size_t idx, std::int32_t dl) {
    sum_[idx] += dl;
    observed_[idx] += obs;
    const int ci = static_cast<int>(idx % static_cast<std::size_t>(geometry_.width));
    const int cj = static_cast<int>(idx / static_cast<std::size_t>(geometry_.width));
    touch(ci, cj);
  };
  for (std::size_t idx : scratch_hits_) apply(idx, hit);
  for (std::size_t idx : scratch_misses_) apply(idx, miss);
}

bool Mapper::moved_enough(const Pose2& a, const Pose2& b) const {
  const double dt = std::hypot(b.x - a.x, b.y - a.y);
  const double dth = std::abs(normalize_angle(b.theta - a.theta));
  return dt + dth * config_.max_range_m > config_.rerender_shift_m;
}

RerenderStats Mapper::rerender(std::uint16_t robot, const SensorPoseFn& sensor_pose_at) {
  RerenderStats st;
  bool any_removed = false;
  for (Stored& s : store_) {
    if (s.info.robot_id != robot) continue;
    ++st.examined;
    const std::optional<Pose2> p = sensor_pose_at(s.info);
    if (!p) continue;
    if (!finite(*p)) {
      ++counters_.rerender_invalid_pose;
      continue;
    }
    if (!moved_enough(s.info.pose, *p)) continue;
    render(s, s.info.pose, -1);
    int i = 0, j = 0;
    if (!geometry_.cell_of(p->x, p->y, &i, &j)) {
      ++counters_.rerender_outside;
      ++st.removed;
      s.removed = true;
      any_removed = true;
      continue;
    }
    render(s, *p, +1);
    s.info.pose = *p;
    ++st.moved;
    ++counters_.rerendered;
  }
  if (any_removed) {
    std::erase_if(store_, [&](const Stored& s) {
      if (s.removed) {
        store_bytes_ -= bytes_of(s);
        return true;
      }
      return false;
    });
  }
  return st;
}

RerenderStats Mapper::on_trajectory_corrected(std::uint16_t robot,
                                              const std::function<std::optional<Pose2>(Nanos)>& robot_pose_at) {
  return rerender(robot, [&](const ScanInfo& info) -> std::optional<Pose2> {
    const std::optional<Pose2> p = robot_pose_at(info.stamp);
    if (!p) return std::nullopt;
    return compose(*p, info.sensor_offset);
  });
}

RerenderStats Mapper::on_frame_corrected(std::uint16_t robot, const Pose2& local_to_global) {
  return rerender(robot, [&](const ScanInfo& info) -> std::optional<Pose2> { return compose(local_to_global, info.local_pose); });
}

double Mapper::log_odds(int i, int j) const {
  const std::int32_t l = std::clamp(sum_[geometry_.index(i, j)], l_min_, l_max_);
  return static_cast<double>(l) * 1e-3;
}

double Mapper::probability(int i, int j) const {
  const double l = log_odds(i, j);
  return 1.0 - 1.0 / (1.0 + std::exp(l));
}

Cell Mapper::classify(int i, int j) const {
  if (!observed(i, j)) return Cell::kUnknown;
  const double p = probability(i, j);
  if (p >= config_.p_o) return Cell::kObstacle;
  if (p <= config_.p_c) return Cell::kClear;
  return Cell::kUnknown;
}

ClassGrid Mapper::classified() const {
  ClassGrid g;
  g.geometry = geometry_;
  g.cells.resize(geometry_.cells());
  for (int j = 0; j < geometry_.height; ++j)
    for (int i = 0; i < geometry_.width; ++i) g.at(i, j) = classify(i, j);
  return g;
}

std::optional<Mapper::Region> Mapper::take_changed() {
  std::optional<Region> r = changed_;
  changed_.reset();
  return r;
}

std::vector<Vec2> Mapper::trajectory(std::uint16_t robot) const {
  std::vector<Vec2> out;
  for (const Stored& s : store_) {
    if (s.info.robot_id == robot) out.push_back(s.info.pose.translation());
  }
  return out;
}

std::vector<TimedPose> Mapper::body_trajectory(std::uint16_t robot) const {
  std::vector<TimedPose> out;
  for (const Stored& s : store_) {
    if (s.info.robot_id == robot) out.push_back({s.info.stamp, compose(s.info.pose, inverse(s.info.sensor_offset))});
  }
  std::stable_sort(out.begin(), out.end(), [](const TimedPose& a, const TimedPose& b) { return a.stamp < b.stamp; });
  return out;
}

std::vector<std::uint16_t> Mapper::robots() const {
  std::vector<std::uint16_t> out;
  for (const auto& [id, n] : seen_) out.push_back(id);
  return out;
}

}  // namespace cairn::mapper
