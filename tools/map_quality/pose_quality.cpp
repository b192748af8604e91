#include "tools/map_quality/pose_quality.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/text_lines.hpp"

namespace cairn::tools {

GroundTruth read_ground_truth(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_ground_truth(text.str(), path);
}

GroundTruth parse_ground_truth(std::string_view text, const std::string& name) {
  GroundTruth g;
  bool have_t0 = false;
  for_each_line(text, [&](std::size_t line_no, const std::string& line) {
    auto fail = [&](const std::string& why) { return std::runtime_error(name + ":" + std::to_string(line_no) + ": " + why); };
    long long t0 = 0;
    if (std::sscanf(line.c_str(), "# t0_monotonic_ns %lld", &t0) == 1) {
      g.t0 = t0;
      have_t0 = true;
      return;
    }
    if (line.empty() || line[0] == '#') return;
    double t = 0, x = 0, y = 0, theta = 0, odo = 0;
    unsigned long robot = 0;
    if (std::sscanf(line.c_str(), "%lf %lu %lf %lf %lf %lf", &t, &robot, &x, &y, &theta, &odo) != 6) {
      throw fail("expected t_s robot x y theta odometer_m");
    }
    if (robot < 1 || robot > 65535) throw fail("robot id outside 1..65535");
    if (!std::isfinite(t) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(theta)) throw fail("not finite");
    auto& v = g.robots[static_cast<std::uint16_t>(robot)];
    if (!v.empty() && t < v.back().t_s) throw fail("time goes backwards for robot " + std::to_string(robot));
    v.push_back({t, {x, y, theta}});
  });
  if (!have_t0) {
    throw std::runtime_error(name + ": no '# t0_monotonic_ns' line (written by cairn-hil since the trajectory scoring)");
  }
  return g;
}

PoseQuality evaluate_poses(const std::vector<mapper::TrajectorySample>& estimates, const GroundTruth& truth) {
  constexpr double kMaxGapS = 0.5;
  std::map<std::uint16_t, RobotPoseQuality> by;
  std::map<std::uint16_t, double> se, se_heading;
  PoseQuality out;
  double se_all = 0;
  for (const mapper::TrajectorySample& e : estimates) {
    RobotPoseQuality& r = by[e.robot];
    r.robot = e.robot;
    const auto it = truth.robots.find(e.robot);
    // In double: a wild stamp minus t0 would overflow the integers.
    const double t = (static_cast<double>(e.stamp) - static_cast<double>(truth.t0)) * 1e-9;
    if (it == truth.robots.end() || it->second.size() < 2) {
      ++r.unscored;
      continue;
    }
    const auto& v = it->second;
    const auto hi = std::lower_bound(v.begin(), v.end(), t, [](const GroundTruth::Sample& s, double x) { return s.t_s < x; });
    if (hi == v.end() || (hi->t_s != t && (hi == v.begin() || hi->t_s - (hi - 1)->t_s > kMaxGapS))) {
      ++r.unscored;
      continue;
    }
    Pose2 p = hi->pose;
    if (hi->t_s != t) {
      const GroundTruth::Sample& a = *(hi - 1);
      const double f = (t - a.t_s) / (hi->t_s - a.t_s);
      p.x = a.pose.x + f * (hi->pose.x - a.pose.x);
      p.y = a.pose.y + f * (hi->pose.y - a.pose.y);
      p.theta = normalize_angle(a.pose.theta + f * normalize_angle(hi->pose.theta - a.pose.theta));
    }
    const double d = std::hypot(e.pose.x - p.x, e.pose.y - p.y);
    const double dh = normalize_angle(e.pose.theta - p.theta);
    ++r.samples;
    se[e.robot] += d * d;
    se_heading[e.robot] += dh * dh;
    r.max_m = std::max(r.max_m, d);
    se_all += d * d;
    ++out.samples;
    out.max_m = std::max(out.max_m, d);
  }
  for (auto& [id, r] : by) {
    if (r.samples > 0) {
      r.rmse_m = std::sqrt(se[id] / static_cast<double>(r.samples));
      r.heading_rmse_rad = std::sqrt(se_heading[id] / static_cast<double>(r.samples));
    }
    out.robots.push_back(r);
  }
  if (out.samples > 0) out.rmse_m = std::sqrt(se_all / static_cast<double>(out.samples));
  return out;
}

std::string to_text(const PoseQuality& q) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(4);
  o << "robot poses         " << q.samples << " scored, rmse " << q.rmse_m << " m, max " << q.max_m << " m\n";
  for (const RobotPoseQuality& r : q.robots) {
    o << "  robot " << r.robot << "           " << r.samples << " scored (" << r.unscored << " not), rmse " << r.rmse_m
      << " m, max " << r.max_m << " m, heading rmse " << r.heading_rmse_rad << " rad\n";
  }
  return o.str();
}

}  // namespace cairn::tools
