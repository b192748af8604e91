#include "firmware/executive/features.hpp"

#include <algorithm>
#include <cmath>

namespace cairn::firmware {

namespace {

void emit(const lms::LmsScan& scan, std::size_t first, std::size_t last, const Pose2& mount, const FeatureConfig& cfg,
          ScanFeatures* out) {
  const auto a0 = scan.angle_min + scan.angle_increment * static_cast<double>(first);
  const auto a1 = scan.angle_min + scan.angle_increment * static_cast<double>(last);
  double sum = 0;
  for (std::size_t i = first; i <= last; ++i) sum += scan.range_mm[i] * 1e-3;
  const double r = sum / static_cast<double>(last - first + 1);
  // Width: the chord between the outer edges of the first and last beam.
  const double width = 2.0 * r * std::sin(0.5 * (a1 - a0 + scan.angle_increment));
  if (width > cfg.max_width_m || r > cfg.max_range_m) return;
  ScanFeature f;
  f.robot = width >= cfg.robot_marker_min_width_m;
  f.width = width;
  const double bearing_s = 0.5 * (a0 + a1);
  double range_s = r;
  if (!f.robot) {
    // The pole's centre: each beam hits the circle of radius R around a centre at
    // distance d along the run's bearing, so d = r cos(δ) + sqrt(R² - (r sin δ)²) per
    // beam (δ = beam angle - bearing); averaged. (Mean range + R overshoots: the edge
    // beams graze the pole and come back long.)
    const double R = cfg.pole_radius_m;
    double d = 0;
    for (std::size_t i = first; i <= last; ++i) {
      const double ri = scan.range_mm[i] * 1e-3;
      const double delta = scan.angle_min + scan.angle_increment * static_cast<double>(i) - bearing_s;
      const double lateral = ri * std::sin(delta);
      d += ri * std::cos(delta) + std::sqrt(std::max(0.0, R * R - lateral * lateral));
    }
    range_s = d / static_cast<double>(last - first + 1);
  }
  // Sensor frame -> robot frame (the mount's offset changes range and bearing).
  const RangeBearing rb = observe_point(Pose2{}, transform_point(mount, point_from_observation(Pose2{}, {range_s, bearing_s})));
  f.range = rb.range;
  f.bearing = rb.bearing;
  const double n = static_cast<double>(last - first + 1);
  f.covariance << cfg.sigma_range_m * cfg.sigma_range_m, 0, 0,
      cfg.sigma_bearing_rad * cfg.sigma_bearing_rad + scan.angle_increment * scan.angle_increment / (12.0 * n);
  if (out->count == out->items.size()) {
    ++out->dropped;
    return;
  }
  out->items[out->count++] = f;
}

}  // namespace

void extract_features(const lms::LmsScan& scan, const Pose2& mount, const FeatureConfig& cfg, ScanFeatures* out) {
  out->count = 0;
  out->dropped = 0;
  std::size_t start = 0;
  bool in_run = false;
  for (std::size_t i = 0; i < scan.count; ++i) {
    const bool reflective = scan.flags[i] != 0 && scan.range_mm[i] != 0;
    if (in_run) {
      const bool continuous = reflective && std::abs(scan.range_mm[i] - scan.range_mm[i - 1]) * 1e-3 <= cfg.max_range_step_m;
      if (!continuous) {
        emit(scan, start, i - 1, mount, cfg, out);
        in_run = false;
      }
    }
    if (reflective && !in_run) {
      start = i;
      in_run = true;
    }
  }
  if (in_run) emit(scan, start, scan.count - 1, mount, cfg, out);
}

}  // namespace cairn::firmware
