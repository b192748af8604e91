#include "tools/eval/scan_eval.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

namespace cairn::eval {

namespace {
using SteadyClock = std::chrono::steady_clock;
double ms_since(SteadyClock::time_point t0) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - t0).count();
}
constexpr double kDeg = std::numbers::pi / 180.0;
}  // namespace

void carmen_points(const CarmenScan& s, double min_range, double max_range, std::vector<Vec2>* out) {
  out->clear();
  const std::size_t n = s.ranges.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double r = static_cast<double>(s.ranges[i]);
    if (!(r > min_range && r < max_range)) continue;
    const double a = carmen_beam_angle(i, n);
    out->emplace_back(r * std::cos(a), r * std::sin(a));
  }
}

std::vector<PairCase> make_pair_cases(const CarmenLog& log, const ScanEvalOptions& o) {
  std::vector<PairCase> cases;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> nxy(0.0, o.sigma_xy_m), nth(0.0, o.sigma_theta_deg * kDeg);
  for (std::size_t i = 0; i + 1 < log.scans.size(); ++i) {
    if (o.max_pairs && cases.size() >= o.max_pairs) break;
    PairCase c;
    c.ref = i;
    c.truth = between(log.scans[i].pose, log.scans[i + 1].pose);
    c.initial = {c.truth.x + nxy(rng), c.truth.y + nxy(rng), normalize_angle(c.truth.theta + nth(rng))};
    cases.push_back(c);
  }
  return cases;
}

Distribution distribution(std::vector<double> v) {
  Distribution d;
  if (v.empty()) return d;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  d.median = at(0.5);
  d.p95 = at(0.95);
  d.p99 = at(0.99);
  d.max = v.back();
  return d;
}

PairSummary summarize_pairs(const std::vector<PairCase>& cases, const std::vector<PairOutcome>& out,
                            const ScanEvalOptions& o) {
  if (cases.size() != out.size()) throw std::logic_error("summarize_pairs: one outcome per case");
  PairSummary s;
  s.pairs = cases.size();
  std::vector<double> exy, eth, ixy, ith, mms, tms;
  std::size_t ok = 0, with_cov = 0, inside = 0;
  double nees_sum = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Pose2 e = between(cases[i].truth, out[i].estimate);
    const Pose2 e0 = between(cases[i].truth, cases[i].initial);
    exy.push_back(std::hypot(e.x, e.y));
    eth.push_back(std::abs(e.theta) / kDeg);
    ixy.push_back(std::hypot(e0.x, e0.y));
    ith.push_back(std::abs(e0.theta) / kDeg);
    mms.push_back(out[i].match_ms);
    tms.push_back(out[i].total_ms);
    if (exy.back() <= o.success_xy_m && eth.back() <= o.success_theta_deg) {
      ++ok;
      if (out[i].has_covariance) {
        // Error of the estimate in the estimate's own parametrisation.
        const Vec3 d(out[i].estimate.x - cases[i].truth.x, out[i].estimate.y - cases[i].truth.y,
                     normalize_angle(out[i].estimate.theta - cases[i].truth.theta));
        const double nees = d.dot(out[i].covariance.ldlt().solve(d));
        nees_sum += nees;
        if (nees <= 7.815) ++inside;  // chi2(3) 95%
        ++with_cov;
      }
    }
  }
  if (with_cov) {
    s.mean_nees = nees_sum / static_cast<double>(with_cov);
    s.within_95_pct = 100.0 * static_cast<double>(inside) / static_cast<double>(with_cov);
  }
  s.err_xy_m = distribution(exy);
  s.err_theta_deg = distribution(eth);
  s.initial_xy_m = distribution(ixy);
  s.initial_theta_deg = distribution(ith);
  s.match_ms = distribution(mms);
  s.total_ms = distribution(tms);
  s.success_rate = cases.empty() ? 0 : static_cast<double>(ok) / static_cast<double>(cases.size());
  return s;
}

std::vector<PairOutcome> run_cairn_pairs(const CarmenLog& log, const std::vector<PairCase>& cases,
                                         const ScanEvalOptions& o) {
  localmap::LikelihoodGrid grid(o.map.grid);
  localmap::ScanMatcher matcher(o.map.match, static_cast<std::size_t>(std::max<int>(o.map.max_points, 8192)));
  std::vector<Vec2> ref, cur;
  std::vector<PairOutcome> out;
  out.reserve(cases.size());
  for (const PairCase& c : cases) {
    carmen_points(log.scans[c.ref], o.map.min_range_m, o.map.max_range_m, &ref);
    carmen_points(log.scans[c.ref + 1], o.map.min_range_m, o.map.max_range_m, &cur);
    const auto t0 = SteadyClock::now();
    grid.reset(Vec2::Zero());
    grid.add_surface(ref, o.map.surface_gap_m);
    grid.finish();
    const auto t1 = SteadyClock::now();
    const localmap::MatchResult m = matcher.match(grid, cur, c.initial);
    PairOutcome r;
    r.match_ms = ms_since(t1);
    r.total_ms = ms_since(t0);
    r.estimate = m.pose;
    r.has_covariance = true;
    r.covariance = m.covariance;
    out.push_back(r);
  }
  return out;
}

namespace {

// Mean relative translation error over segments of `length` metres of reference path.
double segment_drift_pct(const std::vector<Pose2>& ref, const std::vector<Pose2>& est, double length) {
  std::vector<double> along(ref.size(), 0.0);
  for (std::size_t i = 1; i < ref.size(); ++i)
    along[i] = along[i - 1] + std::hypot(ref[i].x - ref[i - 1].x, ref[i].y - ref[i - 1].y);
  double sum = 0;
  std::size_t n = 0, j = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    j = std::max(j, i);
    while (j < ref.size() && along[j] - along[i] < length) ++j;
    if (j == ref.size()) break;
    const Pose2 dr = between(ref[i], ref[j]), de = between(est[i], est[j]);
    sum += std::hypot(dr.x - de.x, dr.y - de.y) / (along[j] - along[i]);
    ++n;
  }
  return n ? 100.0 * sum / static_cast<double>(n) : 0.0;
}

}  // namespace

DriftSummary run_local_mapper(const CarmenLog& log, const ScanEvalOptions& o) {
  DriftSummary d;
  if (log.scans.size() < 2) return d;
  localmap::LocalMapper mapper(o.map);
  mapper.reset(log.scans[0].pose);
  std::mt19937_64 rng(o.seed + 1);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Pose2> ref, est, odo;
  std::vector<double> times;
  std::vector<Vec2> pts;
  Pose2 odom_pose = log.scans[0].pose;
  for (std::size_t i = 0; i < log.scans.size(); ++i) {
    Pose2 delta;
    Mat3 cov = Mat3::Identity() * 1e-6;
    if (i > 0) {
      const Pose2 truth = between(log.scans[i - 1].pose, log.scans[i].pose);
      const double dist = std::hypot(truth.x, truth.y);
      const double sxy = o.odom_noise_xy * dist + 0.005;
      const double sth = o.odom_noise_theta * std::abs(truth.theta) + o.odom_noise_theta_per_m * dist + 0.002;
      delta = {truth.x + sxy * unit(rng), truth.y + sxy * unit(rng), normalize_angle(truth.theta + sth * unit(rng))};
      cov = Vec3(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
      d.path_m += dist;
    }
    odom_pose = i ? compose(odom_pose, delta) : odom_pose;
    carmen_points(log.scans[i], o.map.min_range_m, o.map.max_range_m, &pts);
    const auto t0 = SteadyClock::now();
    const auto u = mapper.add_scan(pts, delta, cov);
    times.push_back(ms_since(t0));
    ref.push_back(log.scans[i].pose);
    est.push_back(u.pose);
    odo.push_back(odom_pose);
  }
  auto final_err = [&](const std::vector<Pose2>& e) {
    const Pose2 a = between(ref.front(), ref.back()), b = between(e.front(), e.back());
    return std::hypot(a.x - b.x, a.y - b.y);
  };
  d.final_error_m = final_err(est);
  d.final_drift_pct = 100.0 * d.final_error_m / std::max(d.path_m, 1e-9);
  d.odom_final_drift_pct = 100.0 * final_err(odo) / std::max(d.path_m, 1e-9);
  d.segment_drift_pct = segment_drift_pct(ref, est, 10.0);
  d.odom_segment_drift_pct = segment_drift_pct(ref, odo, 10.0);
  d.scans = mapper.counters().scans;
  d.matched = mapper.counters().matched;
  d.rejected = mapper.counters().rejected;
  d.update_ms = distribution(times);
  return d;
}

}  // namespace cairn::eval
