#include "firmware/executive/features.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "firmware/executive/marker_decoder.hpp"

namespace cairn::firmware {

namespace {

void add(const ScanFeature& f, ScanFeatures* out) {
  if (out->count == out->items.size()) {
    ++out->dropped;
    return;
  }
  out->items[out->count++] = f;
}

void emit(const lms::LmsScan& scan, std::size_t first, std::size_t last, const Pose2& mount, const FeatureConfig& cfg,
          ScanFeatures* out) {
  const auto a0 = scan.angle(first);
  const auto a1 = scan.angle(last);
  double sum = 0;
  for (std::size_t i = first; i <= last; ++i) sum += scan.range_mm[i] * 1e-3;
  const double r = sum / static_cast<double>(last - first + 1);
  // Width: the chord between the outer edges of the first and last beam.
  const double width = 2.0 * r * std::sin(0.5 * (a1 - a0 + scan.angle_increment));
  if (width > cfg.max_width_m || r > cfg.max_range_m) return;
  ScanFeature f;
  f.robot = width >= cfg.robot_marker_min_width_m;
  // Wider than a pole by more than two beams' spacing, narrower than a marker: a stripe of
  // a body whose bare neighbours are hidden (another robot behind it): not a feature.
  if (!f.robot && width > 2 * cfg.pole_radius_m + 2 * r * scan.angle_increment) return;
  f.width = width;
  f.first_beam = static_cast<std::uint16_t>(first);
  f.last_beam = static_cast<std::uint16_t>(last);
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
      const double delta = scan.angle(i) - bearing_s;
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
  add(f, out);
}

// Cluster [first, last] if it is one whole taped object: a pole, or (wide) a marker too far
// or too cut to fit a body. A run with bare beams of the same surface beside it is a
// stripe of a larger taped body (another robot seen in part), and a cluster with a nearer
// return or the field of view's end beside it may be hidden in part: both are left out. (So would be a pole closer
// than the range step to a wall behind it; docs/markers.md.)
void emit_runs(const lms::LmsScan& scan, std::size_t first, std::size_t last, const Pose2& mount, const FeatureConfig& cfg,
               ScanFeatures* out) {
  std::size_t start = 0;
  bool in_run = false;
  // Something nearer right beside the cluster, or the end of the field of view, may hide
  // part of it: then its size is not known, and a sliver of a body can pass for a pole.
  const bool hidden = first == 0 || last + 1 == scan.count ||
                      (scan.range_mm[first - 1] != 0 && scan.range_mm[first - 1] < scan.range_mm[first]) ||
                      (scan.range_mm[last + 1] != 0 && scan.range_mm[last + 1] < scan.range_mm[last]);
  auto close = [&](std::size_t end) {
    if (start == first && end == last && !hidden) emit(scan, start, end, mount, cfg, out);
    in_run = false;
  };
  for (std::size_t i = first; i <= last; ++i) {
    const bool flagged = scan.flags[i] != 0;
    if (in_run && !flagged) close(i - 1);
    if (flagged && !in_run) {
      start = i;
      in_run = true;
    }
  }
  if (in_run) close(last);
}

Vec2 beam_point(const lms::LmsScan& scan, std::size_t i) {
  const double a = scan.angle(i);
  const double r = scan.range_mm[i] * 1e-3;
  return {r * std::cos(a), r * std::sin(a)};
}

// A fitted body centre's (range, bearing) covariance in the robot frame: the Gauss-Newton
// fit's s²(JᵀJ)⁻¹ (sensor frame; s² the residuals' variance with two parameters fitted,
// floored) plus the motion allowance, rotated by the mount and taken through the Jacobian of
// range and bearing at the centre `p` (robot frame).
Mat2 body_covariance(const Mat2& jtj, double sq, std::size_t n, const Pose2& mount, const Vec2& p, const FeatureConfig& cfg) {
  const double s2 = std::max(sq / static_cast<double>(n - 2), cfg.body_sigma_floor_m * cfg.body_sigma_floor_m);
  const Mat2 fit = s2 * jtj.inverse() + cfg.body_sigma_motion_m * cfg.body_sigma_motion_m * Mat2::Identity();
  const Mat2 rot = mount.rotation();
  const Mat2 xy = rot * fit * rot.transpose();
  const double r2 = std::max(p.squaredNorm(), 1e-12), r = std::sqrt(r2);
  Mat2 j;
  j << p.x() / r, p.y() / r, -p.y() / r2, p.x() / r2;
  return j * xy * j.transpose();
}

// Cluster [first, last] as a robot's body: a circle of the fleet's body radius, convex
// towards the laser, fitted to its points (Gauss-Newton on the centre, a fixed number of
// steps). If it is one, `*f` is the robot at the body's centre with the code its tape says.
bool fit_body(const lms::LmsScan& scan, std::size_t first, std::size_t last, const Pose2& mount, const FeatureConfig& cfg,
              ScanFeature* f) {
  const std::size_t n = last - first + 1;
  if (n < 4) return false;
  const Vec2 a = beam_point(scan, first), b = beam_point(scan, last);
  const double chord = (b - a).norm(), R = cfg.robot_radius_m;
  if (chord < cfg.robot_marker_min_width_m || chord > 2 * R + cfg.max_range_step_m) return false;
  Vec2 mean = Vec2::Zero();
  for (std::size_t i = first; i <= last; ++i) mean += beam_point(scan, i);
  mean /= static_cast<double>(n);
  Vec2 c = mean + R * mean.normalized();
  for (int step = 0; step < 8; ++step) {
    Mat2 jtj = Mat2::Zero();
    Vec2 jtr = Vec2::Zero();
    for (std::size_t i = first; i <= last; ++i) {
      const Vec2 d = beam_point(scan, i) - c;
      const double len = std::max(d.norm(), 1e-9);
      const Vec2 jac = -d / len;
      jtj += jac * jac.transpose();
      jtr += jac * (len - R);
    }
    const double det = jtj(0, 0) * jtj(1, 1) - jtj(0, 1) * jtj(1, 0);
    if (std::abs(det) < 1e-12) return false;
    c -= Vec2(jtj(1, 1) * jtr.x() - jtj(0, 1) * jtr.y(), jtj(0, 0) * jtr.y() - jtj(1, 0) * jtr.x()) / det;
  }
  double sq = 0;
  Mat2 jtj = Mat2::Zero();
  for (std::size_t i = first; i <= last; ++i) {
    const Vec2 d = beam_point(scan, i) - c;
    const double len = std::max(d.norm(), 1e-9);
    sq += (len - R) * (len - R);
    jtj += d * d.transpose() / (len * len);
  }
  // Not a body: points off the circle, or the circle behind the laser's side of them
  // (the inside of a curved wall).
  if (!(std::sqrt(sq / static_cast<double>(n)) <= cfg.body_fit_rms_m) || !(c.norm() > mean.norm())) return false;
  if (!(jtj.determinant() > 1e-12)) return false;  // points along one line through the centre: no covariance

  // Each beam placed round the body: where its line meets the circle (measured ranges are
  // noisiest at grazing beams), as an angle round the centre from the point facing the laser.
  std::array<BodyBeam, lms::kMaxBeams> beams;
  const double facing = std::atan2(-c.y(), -c.x());
  for (std::size_t i = first; i <= last; ++i) {
    const double ang = scan.angle(i);
    const Vec2 u(std::cos(ang), std::sin(ang));
    const double offset = u.x() * c.y() - u.y() * c.x();  // the centre's side distance from the beam's line
    const Vec2 hit = (u.dot(c) - std::sqrt(std::max(0.0, R * R - offset * offset))) * u;
    beams[i - first] = {normalize_angle(std::atan2(hit.y() - c.y(), hit.x() - c.x()) - facing), scan.flags[i] != 0};
  }
  // Too few beams to place them round the body with confidence: no code read.
  const int code = n >= cfg.marker_min_beams ? decode_marker(beams.data(), n, cfg.marker_margin_rad) : kMarkerUnread;
  f->robot = true;
  f->marker_id = code > 0 ? code : kMarkerUnread;
  f->width = chord;
  f->first_beam = static_cast<std::uint16_t>(first);
  f->last_beam = static_cast<std::uint16_t>(last);
  // Sensor frame -> robot frame.
  const RangeBearing rb = observe_point(Pose2{}, transform_point(mount, c));
  f->range = rb.range;
  f->bearing = rb.bearing;
  f->covariance = body_covariance(jtj, sq, n, mount, transform_point(mount, c), cfg);
  return true;
}

}  // namespace

void extract_features(const lms::LmsScan& scan, const Pose2& mount, const FeatureConfig& cfg, ScanFeatures* out) {
  out->count = 0;
  out->dropped = 0;
  // Clusters: neighbouring beams with a return and continuous range (one surface).
  auto cluster_end = [&](std::size_t i, bool* flagged) {
    std::size_t j = i;
    *flagged = scan.flags[i] != 0;
    while (j + 1 < scan.count && scan.range_mm[j + 1] != 0 &&
           std::abs(scan.range_mm[j + 1] - scan.range_mm[j]) * 1e-3 <= cfg.max_range_step_m) {
      ++j;
      *flagged = *flagged || scan.flags[j] != 0;
    }
    return j;
  };
  auto has_return = [&](std::size_t i) { return i < scan.count && scan.range_mm[i] != 0; };
  std::size_t i = 0;
  while (i < scan.count) {
    if (scan.range_mm[i] == 0) {
      ++i;
      continue;
    }
    bool flagged = false, more = false;
    const std::size_t j = cluster_end(i, &flagged);
    // A beam grazing a body's edge can land further than the range step from its
    // neighbour: a body is tried first with up to two such beams on either side. If it
    // only fits without them, they are clusters of their own (the occlusion rule keeps
    // a grazing beam, farther than the body beside it, from being a pole; a pole in
    // front of the body stays one).
    std::size_t core_lo = i, hi = j;
    bool any_flagged = flagged;
    if (j - i < 2 && has_return(j + 1)) {
      core_lo = j + 1;
      hi = cluster_end(j + 1, &more);
      any_flagged = any_flagged || more;
    }
    if (has_return(hi + 1)) {
      const std::size_t k = cluster_end(hi + 1, &more);
      if (k - hi <= 2) {
        hi = k;
        any_flagged = any_flagged || more;
      }
    }
    ScanFeature body;
    if (hi != j && any_flagged && fit_body(scan, i, hi, mount, cfg, &body)) {
      add(body, out);
      i = hi + 1;
      continue;
    }
    if (core_lo != i) {  // a leading sliver: on its own, then the cluster after it
      if (flagged) emit_runs(scan, i, j, mount, cfg, out);
      i = core_lo;
      continue;
    }
    if (flagged && fit_body(scan, i, j, mount, cfg, &body)) {
      add(body, out);
      i = j + 1;
      continue;
    }
    if (flagged) emit_runs(scan, i, j, mount, cfg, out);
    i = j + 1;
  }
}

}  // namespace cairn::firmware
