#include "firmware/executive/protective_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace cairn::firmware {

std::string ProtectiveFieldConfig::check(double max_v, double max_acc, double laser_range_m) const {
  if (!enabled) return {};
  if (!(radius_m > 0)) return "field_radius_m must be above 0";
  const double reach = max_v * reaction_s + max_v * max_v / (2 * max_acc) + front_margin_m + radius_m;
  if (!(reach < laser_range_m)) {
    return "the protective field reaches " + std::to_string(reach) + " m at max_v, beyond the laser's " +
           std::to_string(laser_range_m) + " m";
  }
  return {};
}

ProtectiveField::ProtectiveField(const ProtectiveFieldConfig& config, double max_v, double max_acc)
    : cfg_(config), max_acc_(max_acc) {
  reach_ = stopping_distance(max_v);
}

double ProtectiveField::stopping_distance(double v) const {
  v = std::abs(v);
  return v * cfg_.reaction_s + v * v / (2 * max_acc_) + cfg_.front_margin_m;
}

double ProtectiveField::speed_for(double free_m) const {
  const double room = free_m - cfg_.front_margin_m;
  if (!(room > 0)) return 0.0;
  const double t = cfg_.reaction_s;
  return max_acc_ * (-t + std::sqrt(t * t + 2 * room / max_acc_));
}

double ProtectiveField::braking_speed_for(double free_m) const {
  const double room = free_m - cfg_.front_margin_m;
  return room > 0 ? std::sqrt(2 * max_acc_ * room) : 0.0;
}

void ProtectiveField::on_scan(const std::uint16_t* range_mm, std::size_t count, double angle_min, double increment,
                              const Pose2& mount) {
  count_ = 0;
  have_scan_ = true;
  count = std::min(count, points_.size());
  for (std::size_t i = 0; i < count; ++i) {
    if (range_mm[i] == 0) continue;  // no return
    const double r = range_mm[i] * 1e-3;
    const double a = angle_min + increment * static_cast<double>(i);
    const Vec2 p = transform_point(mount, Vec2(r * std::cos(a), r * std::sin(a)));
    if (p.squaredNorm() < cfg_.radius_m * cfg_.radius_m * 0.81) continue;  // well inside the body: its own parts
    points_[count_++] = p;
  }
}

FieldLimit ProtectiveField::limit(double v, double w, const Pose2& since_scan) const {
  FieldLimit out;
  out.reverse_max_v = cfg_.reverse_max_v;
  if (!cfg_.enabled) {
    out.forward_max_v = std::numeric_limits<double>::infinity();
    out.brake_max_v = std::numeric_limits<double>::infinity();
    out.reverse_max_v = std::numeric_limits<double>::infinity();
    out.free_m = std::numeric_limits<double>::infinity();
    return out;
  }
  if (!have_scan_) return out;  // nothing seen yet: no forward motion
  if (!std::isfinite(v) || !std::isfinite(w)) return out;  // no arc to check: blocked
  // The arc driven: curvature w/v, mirrored to turn left (a straight line below 1e-3 /m).
  const double kappa = v > 0 ? w / v : 0.0;
  const bool mirror = kappa < 0;
  const double k = std::abs(kappa);
  const double band = cfg_.radius_m + cfg_.side_margin_m;
  const Pose2 back = inverse(since_scan);
  double free = reach_;
  for (std::size_t i = 0; i < count_; ++i) {
    Vec2 q = transform_point(back, points_[i]);
    if (mirror) q.y() = -q.y();
    double s;        // free travel until the widened body touches q
    bool inside;     // q is inside the widened body now
    bool ahead;      // ... and moving on takes the body deeper
    if (k < 1e-3) {  // straight
      if (std::abs(q.y()) > band) continue;
      const double half = std::sqrt(band * band - q.y() * q.y());
      s = q.x() - half;
      inside = std::abs(q.x()) <= half;
      ahead = q.x() > 0;
      if (!inside && !ahead) continue;  // behind the body: driving on never reaches it
    } else {
      const double rho = 1.0 / k;  // the centre of the turn is (0, rho)
      const double dx = q.x(), dy = rho - q.y();
      const double d = std::hypot(dx, dy);
      if (std::abs(d - rho) > band) continue;  // outside the swept ring
      const double phi = std::atan2(dx, dy);   // q's angle round the centre, from the start
      const double c = d > 1e-9 ? (rho * rho + d * d - band * band) / (2 * rho * d) : -1.0;
      const double half = std::acos(std::clamp(c, -1.0, 1.0));  // the disc covers q over phi ± half
      inside = std::abs(phi) <= half;
      ahead = phi > 0 || rho < band;  // a turn tighter than the body never leaves it
      double start = phi - half;
      if (start < 0 && !inside) start += 2 * std::numbers::pi;  // behind: reached after going round
      s = rho * start;
    }
    if (inside) {
      if (!ahead) continue;
      s = 0;
    }
    if (s < free) {
      free = s;
      out.nearest = mirror ? Vec2(q.x(), -q.y()) : q;
      out.limited = true;
    }
  }
  out.free_m = std::max(free, 0.0);
  out.forward_max_v = out.limited ? speed_for(out.free_m) : std::numeric_limits<double>::infinity();
  out.brake_max_v = out.limited ? braking_speed_for(out.free_m) : std::numeric_limits<double>::infinity();
  return out;
}

}  // namespace cairn::firmware
