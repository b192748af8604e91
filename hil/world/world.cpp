#include "hil/world/world.hpp"

#include "common/robot_marker.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace cairn::hil {

World World::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open world file");
  std::stringstream ss;
  ss << in.rdbuf();
  // A directory opens as a stream that reads nothing: it would load as an empty world.
  if (in.bad() || std::filesystem::is_directory(path)) throw std::runtime_error(path + ": cannot read world file");
  return parse(ss.str(), path);
}

namespace {

constexpr double kMaxRandomCells = 1e6;

// A robot id as the world file may give it: an integer in the range of the wire's uint16.
bool robot_id(double v) { return v >= 1 && v <= 65535 && v == std::floor(v); }

}  // namespace

World World::parse(const std::string& text, const std::string& name) {
  World w;
  w.name_ = name;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  auto fail = [&](const std::string& msg) { throw std::runtime_error(name + ":" + std::to_string(lineno) + ": " + msg); };
  while (std::getline(in, line)) {
    ++lineno;
    if (const auto h = line.find('#'); h != std::string::npos) line.resize(h);
    std::istringstream ls(line);
    std::string kw;
    if (!(ls >> kw)) continue;
    auto nums = [&](int n) {
      std::vector<double> v(static_cast<std::size_t>(n));
      for (double& x : v) {
        if (!(ls >> x) || !std::isfinite(x)) fail("'" + kw + "' expects " + std::to_string(n) + " numbers");
      }
      std::string extra;
      if (ls >> extra) fail("'" + kw + "': unexpected '" + extra + "'");
      return v;
    };
    if (kw == "bounds") {
      const auto v = nums(4);
      if (v[2] <= v[0] || v[3] <= v[1]) fail("bounds: max must exceed min");
      w.bounds_ = {v[0], v[1], v[2], v[3]};
    } else if (kw == "wall") {
      const auto v = nums(4);
      w.segments_.push_back({{v[0], v[1]}, {v[2], v[3]}});
    } else if (kw == "box") {
      const auto v = nums(4);
      if (v[2] <= 0 || v[3] <= 0) fail("box: width and height must be positive");
      const Vec2 a{v[0], v[1]}, b{v[0] + v[2], v[1]}, c{v[0] + v[2], v[1] + v[3]}, d{v[0], v[1] + v[3]};
      w.segments_.insert(w.segments_.end(), {{a, b}, {b, c}, {c, d}, {d, a}});
    } else if (kw == "circle" || kw == "pole") {
      const auto v = nums(3);
      if (v[2] <= 0) fail(kw + ": radius must be positive");
      w.circles_.push_back({{v[0], v[1]}, v[2], kw == "pole", 0});
    } else if (kw == "start") {
      const auto v = nums(4);
      if (!robot_id(v[0])) fail("start: the robot id must be an integer in 1..65535");
      w.starts_.emplace_back(static_cast<int>(v[0]), Pose2{v[1], v[2], v[3]});
    } else if (kw == "route") {
      // route ID X1 Y1 [X2 Y2 ...]: a variable count, so not through nums().
      double id = 0;
      if (!(ls >> id) || !robot_id(id)) fail("route: expects a robot id (an integer in 1..65535) first");
      std::vector<Vec2> pts;
      double x = 0, y = 0;
      while (ls >> x) {
        if (!(ls >> y) || !std::isfinite(x) || !std::isfinite(y)) fail("route: expects x y pairs after the id");
        pts.emplace_back(x, y);
      }
      if (!ls.eof()) fail("route: expects numbers after the id");
      if (pts.empty()) fail("route: needs at least one x y waypoint");
      auto& r = w.routes_.emplace_back(static_cast<int>(id), std::vector<Vec2>{});
      r.second = std::move(pts);
    } else if (kw == "random") {
      const auto v = nums(3);
      if (v[0] <= 0 || v[0] >= 0.6 || v[2] <= 0) fail("random FRACTION SEED CELL: fraction in (0, 0.6), cell > 0");
      if (v[1] < 0 || v[1] > 1e15 || v[1] != std::floor(v[1])) fail("random: the seed must be an integer in 0..1e15");
      // Square obstacles on a grid of CELL-sized cells, keeping robots' starts free.
      std::mt19937_64 rng(static_cast<std::uint64_t>(v[1]));
      const double cell = v[2];
      const double fx = (w.bounds_.xmax - w.bounds_.xmin) / cell, fy = (w.bounds_.ymax - w.bounds_.ymin) / cell;
      // Checked in floating point first: the counts must fit an int and the grid memory.
      if (!(fx * fy <= kMaxRandomCells)) fail("random: bounds / cell give more than 10^6 cells");
      const int nx = static_cast<int>(fx), ny = static_cast<int>(fy);
      const int want = static_cast<int>(v[0] * nx * ny);
      std::vector<char> used(static_cast<std::size_t>(nx * ny), 0);
      int placed = 0, tries = 0;
      while (placed < want && tries++ < 100 * want + 1000) {
        const int i = static_cast<int>(rng() % static_cast<std::uint64_t>(nx)), j = static_cast<int>(rng() % static_cast<std::uint64_t>(ny));
        if (used[static_cast<std::size_t>(j * nx + i)]) continue;
        const Vec2 corner{w.bounds_.xmin + i * cell, w.bounds_.ymin + j * cell};
        bool near_start = false;
        for (const auto& [id, p] : w.starts_) {
          if ((p.translation() - (corner + Vec2(cell / 2, cell / 2))).norm() < 1.5 * cell + 0.5) near_start = true;
        }
        if (near_start) continue;
        used[static_cast<std::size_t>(j * nx + i)] = 1;
        const Vec2 a = corner, b = corner + Vec2(cell, 0), c = corner + Vec2(cell, cell), d = corner + Vec2(0, cell);
        w.segments_.insert(w.segments_.end(), {{a, b}, {b, c}, {c, d}, {d, a}});
        ++placed;
      }
    } else {
      fail("unknown keyword '" + kw + "' (expected bounds, wall, box, circle, pole, start, route, random)");
    }
  }
  return w;
}

namespace {

// Distance along the unit ray (o, d) to segment ab, or a negative number.
double ray_segment(const Vec2& o, const Vec2& d, const Vec2& a, const Vec2& b) {
  const Vec2 e = b - a;
  const double den = d.x() * e.y() - d.y() * e.x();
  if (std::abs(den) < 1e-12) return -1;  // parallel
  const Vec2 ao = a - o;
  const double t = (ao.x() * e.y() - ao.y() * e.x()) / den;
  const double u = (ao.x() * d.y() - ao.y() * d.x()) / den;
  if (t < 0 || u < 0 || u > 1) return -1;
  return t;
}

// Distance along the unit ray to the circle's surface from outside, or negative.
double ray_circle(const Vec2& o, const Vec2& d, const Vec2& c, double r) {
  const Vec2 oc = o - c;
  const double b = oc.dot(d);
  const double q = oc.squaredNorm() - r * r;
  if (q < 0) return -1;  // origin inside: the sensor cannot see this circle
  const double disc = b * b - q;
  if (disc < 0) return -1;
  const double t = -b - std::sqrt(disc);
  return t >= 0 ? t : -1;
}

}  // namespace

RayHit World::cast(const Vec2& origin, double angle, double max_range, int ignore_robot) const {
  const Vec2 d{std::cos(angle), std::sin(angle)};
  RayHit best;
  best.range = max_range;
  for (const Segment& s : segments_) {
    const double t = ray_segment(origin, d, s.a, s.b);
    if (t >= 0 && t < best.range) best = {t, true, false, 0};
  }
  for (const Circle& c : circles_) {
    if (c.robot && c.robot == ignore_robot) continue;
    const double t = ray_circle(origin, d, c.c, c.r);
    if (t < 0 || t >= best.range) continue;
    bool reflective = c.reflective;
    if (c.robot) {  // the tape at the point hit, in the robot's body frame
      const Vec2 on_body = origin + t * d - c.c;
      reflective = marker::taped_at(c.robot, std::atan2(on_body.y(), on_body.x()) - c.heading);
    }
    best = {t, true, reflective, c.robot};
  }
  return best;
}

void World::set_robot(int id, const Pose2& pose, double radius) {
  for (Circle& c : circles_) {
    if (c.robot == id) {
      c.c = pose.translation();
      c.r = radius;
      c.heading = pose.theta;
      return;
    }
  }
  circles_.push_back({pose.translation(), radius, true, id, pose.theta});
}

void World::remove_robot(int id) {
  std::erase_if(circles_, [id](const Circle& c) { return c.robot == id; });
}

bool World::collides(const Vec2& p, double r, int ignore_robot) const {
  for (const Segment& s : segments_) {
    const Vec2 e = s.b - s.a;
    const double u = std::clamp((p - s.a).dot(e) / std::max(e.squaredNorm(), 1e-12), 0.0, 1.0);
    if ((s.a + u * e - p).norm() < r) return true;
  }
  for (const Circle& c : circles_) {
    if (c.robot && c.robot == ignore_robot) continue;
    if ((c.c - p).norm() < r + c.r) return true;
  }
  return false;
}

std::vector<Vec2> World::poles() const {
  std::vector<Vec2> out;
  for (const Circle& c : circles_) {
    if (c.reflective && !c.robot) out.push_back(c.c);
  }
  return out;
}

std::vector<Vec2> World::route(int id) const {
  std::vector<Vec2> out;
  for (const auto& [i, r] : routes_) {
    if (i == id) out.insert(out.end(), r.begin(), r.end());
  }
  return out;
}

std::optional<Pose2> World::start(int id) const {
  for (const auto& [i, p] : starts_) {
    if (i == id) return p;
  }
  return std::nullopt;
}

}  // namespace cairn::hil
