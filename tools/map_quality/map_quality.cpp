#include "tools/map_quality/map_quality.hpp"

#include "tools/map_quality/drivable_space.hpp"
#include "tools/map_quality/pose_quality.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace cairn::tools {

using mapper::Cell;
using mapper::ClassGrid;
using mapper::GridGeometry;

namespace {

// Closed segment / closed axis-aligned box intersection (Liang-Barsky clipping).
bool segment_touches_box(const Vec2& a, const Vec2& b, double x0, double y0, double x1, double y1) {
  double t0 = 0, t1 = 1;
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a.x() - x0, x1 - a.x(), a.y() - y0, y1 - a.y()};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
    } else {
      const double t = q[k] / p[k];
      if (p[k] < 0)
        t0 = std::max(t0, t);
      else
        t1 = std::min(t1, t);
      if (t0 > t1) return false;
    }
  }
  return true;
}

// Does the circle's outline (not its interior) touch the closed box?
bool circle_outline_touches_box(const Vec2& c, double r, double x0, double y0, double x1, double y1) {
  const double nx = std::clamp(c.x(), x0, x1), ny = std::clamp(c.y(), y0, y1);
  const double dmin = std::hypot(nx - c.x(), ny - c.y());
  double dmax = 0;
  for (double x : {x0, x1})
    for (double y : {y0, y1}) dmax = std::max(dmax, std::hypot(x - c.x(), y - c.y()));
  return dmin <= r && r <= dmax;
}

double point_segment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 e = b - a;
  const double u = std::clamp((p - a).dot(e) / std::max(e.squaredNorm(), 1e-18), 0.0, 1.0);
  return (a + u * e - p).norm();
}

}  // namespace

double distance_to_wall(const hil::World& world, const Vec2& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const hil::Segment& s : world.segments()) best = std::min(best, point_segment(p, s.a, s.b));
  for (const hil::Circle& c : world.circles()) {
    if (c.robot) continue;
    best = std::min(best, std::abs((p - c.c).norm() - c.r));
  }
  return best;
}

Vec2 default_start(const hil::World& world) {
  if (const auto s = world.start(1)) return s->translation();
  const auto& b = world.bounds();
  return {(b.xmin + b.xmax) / 2, (b.ymin + b.ymax) / 2};
}

TruthGrid rasterise(const hil::World& world, const GridGeometry& g, const Vec2& start) {
  TruthGrid t;
  t.geometry = g;
  t.cells.assign(g.cells(), Truth::kOther);
  const double res = g.resolution, eps = 1e-9;
  auto cell_range = [&](double lo, double hi, double origin, int n, int* a, int* b) {
    *a = std::max(0, static_cast<int>(std::floor((lo - origin) / res - eps)));
    *b = std::min(n - 1, static_cast<int>(std::floor((hi - origin) / res + eps)));
  };
  auto mark = [&](double bx0, double by0, double bx1, double by1, const auto& touches) {
    int i0 = 0, i1 = 0, j0 = 0, j1 = 0;
    cell_range(bx0, bx1, g.origin_x, g.width, &i0, &i1);
    cell_range(by0, by1, g.origin_y, g.height, &j0, &j1);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const double x0 = g.origin_x + i * res - eps, y0 = g.origin_y + j * res - eps;
        if (touches(x0, y0, x0 + res + 2 * eps, y0 + res + 2 * eps)) t.cells[g.index(i, j)] = Truth::kWall;
      }
    }
  };
  for (const hil::Segment& s : world.segments()) {
    mark(std::min(s.a.x(), s.b.x()), std::min(s.a.y(), s.b.y()), std::max(s.a.x(), s.b.x()), std::max(s.a.y(), s.b.y()),
         [&](double x0, double y0, double x1, double y1) { return segment_touches_box(s.a, s.b, x0, y0, x1, y1); });
  }
  for (const hil::Circle& c : world.circles()) {
    if (c.robot) continue;
    mark(c.c.x() - c.r, c.c.y() - c.r, c.c.x() + c.r, c.c.y() + c.r,
         [&](double x0, double y0, double x1, double y1) { return circle_outline_touches_box(c.c, c.r, x0, y0, x1, y1); });
  }
  int si = 0, sj = 0;
  if (!g.cell_of(start.x(), start.y(), &si, &sj))
    throw std::invalid_argument("map quality: start point (" + std::to_string(start.x()) + ", " + std::to_string(start.y()) +
                                ") is outside the map");
  if (t.at(si, sj) == Truth::kWall)
    throw std::invalid_argument("map quality: start point (" + std::to_string(start.x()) + ", " + std::to_string(start.y()) +
                                ") is in a wall cell; give another with --start");
  std::deque<std::pair<int, int>> q{{si, sj}};
  t.cells[g.index(si, sj)] = Truth::kFree;
  while (!q.empty()) {
    const auto [i, j] = q.front();
    q.pop_front();
    const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int ni = i + di[k], nj = j + dj[k];
      if (!g.contains(ni, nj)) continue;
      Truth& c = t.cells[g.index(ni, nj)];
      if (c != Truth::kOther) continue;
      c = Truth::kFree;
      q.emplace_back(ni, nj);
    }
  }
  return t;
}

ClassGrid truth_as_map(const TruthGrid& truth) {
  ClassGrid m;
  m.geometry = truth.geometry;
  m.cells.resize(truth.cells.size());
  for (std::size_t k = 0; k < truth.cells.size(); ++k)
    m.cells[k] = truth.cells[k] == Truth::kWall ? Cell::kObstacle : truth.cells[k] == Truth::kFree ? Cell::kClear : Cell::kUnknown;
  return m;
}

Reference make_reference(const hil::World& world, const GridGeometry& geometry, const Vec2& start, double robot_radius_m) {
  if (!(std::isfinite(robot_radius_m) && robot_radius_m >= 0))
    throw std::invalid_argument("map quality: robot radius must be finite and >= 0 (got " + std::to_string(robot_radius_m) + ")");
  Reference r;
  r.truth = rasterise(world, geometry, start);
  r.robot_radius_m = robot_radius_m;
  if (robot_radius_m > 0) {
    r.drivable = drivable_space(world, geometry, start, robot_radius_m);
    for (std::size_t k = 0; k < r.drivable.size(); ++k) r.drivable[k] = r.drivable[k] && r.truth.cells[k] == Truth::kFree;
  }
  return r;
}

MapQuality evaluate(const ClassGrid& map, const hil::World& world, const Vec2& start) {
  return evaluate(map, make_reference(world, map.geometry, start), world);
}

MapQuality evaluate(const ClassGrid& map, const Reference& reference, const hil::World& world) {
  const GridGeometry& g = map.geometry;
  const GridGeometry& rg = reference.truth.geometry;
  if (g.width != rg.width || g.height != rg.height || g.resolution != rg.resolution || g.origin_x != rg.origin_x ||
      g.origin_y != rg.origin_y)
    throw std::invalid_argument("map quality: the map's grid is not the reference's");
  const TruthGrid& truth = reference.truth;
  const bool drivable = !reference.drivable.empty();
  MapQuality q;
  q.resolution = g.resolution;
  q.robot_radius_m = reference.robot_radius_m;
  std::vector<double> offsets;
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      const Truth t = truth.at(i, j);
      const Cell c = map.at(i, j);
      const bool drives = drivable && reference.drivable[g.index(i, j)];
      q.free_cells += t == Truth::kFree;
      q.wall_cells += t == Truth::kWall;
      q.drivable_cells += drives;
      if (c == Cell::kUnknown) continue;
      ++q.known;
      q.known_free += t == Truth::kFree;
      q.known_drivable += drives;
      if (c == Cell::kObstacle) {
        ++q.obstacle;
        if (t == Truth::kWall)
          ++q.agree;
        else
          ++q.false_obstacles;
        offsets.push_back(distance_to_wall(world, g.center(i, j)));
      } else {
        ++q.clear;
        if (t == Truth::kFree)
          ++q.agree;
        else
          ++q.false_free;
      }
    }
  }
  auto ratio = [](std::size_t a, std::size_t b) { return b ? static_cast<double>(a) / static_cast<double>(b) : 0.0; };
  q.coverage = ratio(q.known_free, q.free_cells);
  q.drivable_coverage = ratio(q.known_drivable, q.drivable_cells);
  q.agreement = ratio(q.agree, q.known);
  q.false_obstacle_rate = ratio(q.false_obstacles, q.known);
  q.false_free_rate = ratio(q.false_free, q.known);
  if (!offsets.empty()) {
    double sum = 0;
    for (double d : offsets) sum += d;
    q.wall_offset_mean_m = sum / static_cast<double>(offsets.size());
    std::sort(offsets.begin(), offsets.end());
    q.wall_offset_max_m = offsets.back();
    q.wall_offset_p95_m = offsets[static_cast<std::size_t>(std::floor(0.95 * static_cast<double>(offsets.size() - 1)))];
  }
  return q;
}

std::string to_text(const MapQuality& q) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(4);
  o << "resolution          " << q.resolution << " m\n"
    << "truth               " << q.free_cells << " free cells (reachable), " << q.wall_cells << " wall cells\n"
    << "known cells         " << q.known << " (" << q.obstacle << " obstacle, " << q.clear << " clear)\n"
    << "coverage            " << 100.0 * q.coverage << " % of the reachable free space known\n";
  if (q.robot_radius_m > 0)
    o << "drivable coverage   " << 100.0 * q.drivable_coverage << " % of the " << q.drivable_cells
      << " free cells a robot of radius " << q.robot_radius_m << " m sweeps from the start\n";
  o << "agreement           " << 100.0 * q.agreement << " % of known cells\n"
    << "false obstacles     " << q.false_obstacles << " (" << 100.0 * q.false_obstacle_rate << " % of known)\n"
    << "false free          " << q.false_free << " (" << 100.0 * q.false_free_rate << " % of known)\n"
    << "wall offset         mean " << q.wall_offset_mean_m << " m, p95 " << q.wall_offset_p95_m << " m, max "
    << q.wall_offset_max_m << " m (max " << q.wall_offset_max_m / q.resolution << " cells)\n";
  return o.str();
}

LandmarkQuality evaluate_landmarks(const std::vector<msg::Landmark>& landmarks, const std::vector<Vec2>& poles, double match_m) {
  LandmarkQuality q;
  q.poles = poles.size();
  q.landmarks = landmarks.size();
  struct Pair {
    double d;
    std::size_t pole, landmark;
  };
  std::vector<Pair> pairs;
  for (std::size_t p = 0; p < poles.size(); ++p) {
    for (std::size_t l = 0; l < landmarks.size(); ++l) {
      const double d = (Vec2(landmarks[l].x, landmarks[l].y) - poles[p]).norm();
      if (d <= match_m) pairs.push_back({d, p, l});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  std::vector<bool> pole_used(poles.size()), landmark_used(landmarks.size());
  double sum = 0, sq = 0;
  for (const Pair& pr : pairs) {
    if (pole_used[pr.pole] || landmark_used[pr.landmark]) continue;
    pole_used[pr.pole] = landmark_used[pr.landmark] = true;
    ++q.matched;
    sum += pr.d;
    sq += pr.d * pr.d;
    q.error_max_m = std::max(q.error_max_m, pr.d);
  }
  if (q.matched > 0) {
    q.error_mean_m = sum / static_cast<double>(q.matched);
    q.error_rms_m = std::sqrt(sq / static_cast<double>(q.matched));
  }
  q.spurious = q.landmarks - q.matched;
  q.missing = q.poles - q.matched;
  return q;
}

std::string to_text(const LandmarkQuality& q) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(4);
  o << "landmarks           " << q.landmarks << " mapped, " << q.poles << " poles in the world: " << q.matched << " matched, "
    << q.spurious << " spurious, " << q.missing << " missing\n"
    << "landmark error      mean " << q.error_mean_m << " m, rms " << q.error_rms_m << " m, max " << q.error_max_m << " m\n";
  return o.str();
}

namespace {

nlohmann::json json_of(const MapQuality& q) {
  nlohmann::json j;
  j["resolution_m"] = q.resolution;
  j["truth_free_cells"] = q.free_cells;
  j["truth_wall_cells"] = q.wall_cells;
  j["known_cells"] = q.known;
  j["obstacle_cells"] = q.obstacle;
  j["clear_cells"] = q.clear;
  j["known_free_cells"] = q.known_free;
  j["coverage"] = q.coverage;
  if (q.robot_radius_m > 0) {
    j["robot_radius_m"] = q.robot_radius_m;
    j["drivable_cells"] = q.drivable_cells;
    j["known_drivable_cells"] = q.known_drivable;
    j["drivable_coverage"] = q.drivable_coverage;
  }
  j["agreement"] = q.agreement;
  j["agree_cells"] = q.agree;
  j["false_obstacles"] = q.false_obstacles;
  j["false_free"] = q.false_free;
  j["false_obstacle_rate"] = q.false_obstacle_rate;
  j["false_free_rate"] = q.false_free_rate;
  j["wall_offset_mean_m"] = q.wall_offset_mean_m;
  j["wall_offset_p95_m"] = q.wall_offset_p95_m;
  j["wall_offset_max_m"] = q.wall_offset_max_m;
  j["wall_offset_mean_cells"] = q.resolution > 0 ? q.wall_offset_mean_m / q.resolution : 0.0;
  j["wall_offset_max_cells"] = q.resolution > 0 ? q.wall_offset_max_m / q.resolution : 0.0;
  return j;
}

nlohmann::json json_of(const LandmarkQuality& q) {
  nlohmann::json j;
  j["poles"] = q.poles;
  j["landmarks"] = q.landmarks;
  j["matched"] = q.matched;
  j["spurious"] = q.spurious;
  j["missing"] = q.missing;
  j["error_mean_m"] = q.error_mean_m;
  j["error_rms_m"] = q.error_rms_m;
  j["error_max_m"] = q.error_max_m;
  return j;
}

}  // namespace

std::string to_json(const LandmarkQuality& q) { return json_of(q).dump(); }

std::string to_json(const MapQuality& q, const LandmarkQuality& l) { return to_json(q, &l, nullptr); }

std::string to_json(const MapQuality& q) { return json_of(q).dump(2); }

std::string to_json(const MapQuality& q, const LandmarkQuality* l, const PoseQuality* p) {
  nlohmann::json j = json_of(q);
  if (l) j["landmarks"] = json_of(*l);
  if (p) {
    nlohmann::json robots = nlohmann::json::array();
    for (const RobotPoseQuality& r : p->robots) {
      robots.push_back({{"robot", r.robot},
                        {"samples", r.samples},
                        {"unscored", r.unscored},
                        {"rmse_m", r.rmse_m},
                        {"max_m", r.max_m},
                        {"heading_rmse_rad", r.heading_rmse_rad}});
    }
    j["poses"] = {{"samples", p->samples}, {"rmse_m", p->rmse_m}, {"max_m", p->max_m}, {"robots", robots}};
  }
  return j.dump();
}

}  // namespace cairn::tools
