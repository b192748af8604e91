#include "firmware/localmap/scan_matcher.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cairn::localmap {

const char* validate(const MatchConfig& c) {
  if (!(c.window_xy_m >= 0 && c.window_xy_m <= 5)) return "window_xy_m must be in [0, 5] m";
  if (!(c.window_theta_rad >= 0 && c.window_theta_rad <= 1.6)) return "window_theta must be in [0, 90] deg";
  if (!(c.step_range_m >= 1 && c.step_range_m <= 100)) return "step_range_m must be in [1, 100] m";
  if (!(c.decimate_m >= 0 && c.decimate_m <= 1)) return "decimate_m must be in [0, 1] m";
  if (c.candidates < 1 || c.candidates > 8) return "candidates must be in [1, 8]";
  if (c.gn_iterations < 0 || c.gn_iterations > 100) return "gn_iterations must be in [0, 100]";
  if (!(c.min_score >= 0 && c.min_score <= 1)) return "min_score must be in [0, 1]";
  if (!(c.sigma_floor_xy_m > 0 && c.sigma_floor_theta_rad > 0)) return "covariance floors must be > 0";
  if (!(c.covariance_scale >= 1 && c.covariance_scale <= 1e4)) return "covariance_scale must be in [1, 1e4]";
  return nullptr;
}

SearchShape search_shape(const GridConfig& g, const MatchConfig& m) {
  SearchShape s;
  const double r2 = 2 * m.step_range_m * m.step_range_m;
  const double res_c = g.resolution_m * g.coarse_factor;
  s.coarse_step = std::acos(std::clamp(1.0 - res_c * res_c / r2, -1.0, 1.0));
  s.coarse_angles = static_cast<int>(std::ceil(m.window_theta_rad / s.coarse_step));
  s.coarse_shifts = static_cast<int>(std::ceil(m.window_xy_m / res_c));
  s.fine_step = std::acos(std::clamp(1.0 - g.resolution_m * g.resolution_m / r2, -1.0, 1.0));
  s.fine_angles = static_cast<int>(std::ceil(0.5 * s.coarse_step / s.fine_step));
  s.fine_shifts = g.coarse_factor / 2;
  return s;
}

ScanMatcher::ScanMatcher(const MatchConfig& cfg, std::size_t max_points)
    : cfg_(cfg), sparse_(max_points), cell_x_(std::make_unique<int[]>(max_points)),
      cell_y_(std::make_unique<int[]>(max_points)) {
  if (const char* e = validate(cfg)) throw std::invalid_argument(std::string("scan matcher: ") + e);
}

void ScanMatcher::keep(const Candidate& c) {
  const int k = cfg_.candidates;
  if (kept_ == k && c.score <= best_[static_cast<std::size_t>(k - 1)].score) return;
  int i = std::min(kept_, k - 1);
  while (i > 0 && best_[static_cast<std::size_t>(i - 1)].score < c.score) {
    best_[static_cast<std::size_t>(i)] = best_[static_cast<std::size_t>(i - 1)];
    --i;
  }
  best_[static_cast<std::size_t>(i)] = c;
  kept_ = std::min(kept_ + 1, k);
}

namespace {
int floor_int(double v) { return static_cast<int>(std::floor(v)); }
}  // namespace

// Whole-cell translations only shift the cell indices, so the correlative stages index the
// sparse points once per angle (rotated, shifted by `offset` from the grid's corner).
void ScanMatcher::index_points(double cs, double sn, const Vec2& offset, double cell) {
  for (std::size_t i = 0; i < sparse_.size(); ++i) {
    const Vec2& p = sparse_[i];
    cell_x_[i] = floor_int((cs * p.x() - sn * p.y() + offset.x()) / cell);
    cell_y_[i] = floor_int((sn * p.x() + cs * p.y() + offset.y()) / cell);
  }
}

ScanMatcher::Candidate ScanMatcher::search_fine(const LikelihoodGrid& grid, const Candidate& c,
                                                const SearchShape& shape) {
  const double res = grid.config().resolution_m;
  const double fine_step = shape.fine_step;
  const int na = shape.fine_angles;
  const int half = shape.fine_shifts;
  const Vec2 origin = grid.origin();
  Candidate best = c;
  best.score = -1;
  const std::size_t n = sparse_.size();
  for (int a = -na; a <= na; ++a) {
    const double th = c.theta + a * fine_step;
    const double cs = std::cos(th), sn = std::sin(th);
    index_points(cs, sn, Vec2(c.x, c.y) - origin, res);
    for (int ty = -half; ty <= half; ++ty) {
      for (int tx = -half; tx <= half; ++tx) {
        double s = 0;
        for (std::size_t i = 0; i < n; ++i) s += static_cast<double>(grid.cell(cell_x_[i] + tx, cell_y_[i] + ty));
        if (s > best.score) best = {th, c.x + tx * res, c.y + ty * res, s};
      }
    }
  }
  return best;
}

Pose2 ScanMatcher::refine(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& start, double* cost,
                          int* iterations) const {
  auto evaluate = [&](const Pose2& pose, Mat3* h, Vec3* b) {
    const double cs = std::cos(pose.theta), sn = std::sin(pose.theta);
    double c = 0;
    if (h) h->setZero();
    if (b) b->setZero();
    for (const Vec2& p : points) {
      const Vec2 q(cs * p.x() - sn * p.y() + pose.x, sn * p.x() + cs * p.y() + pose.y);
      Vec2 g;
      const double r = 1.0 - grid.sample(q, &g);
      c += r * r;
      if (h) {
        // dr/dξ = -∇M · dq/dξ, dq/dθ = (-s px - c py, c px - s py)
        const Vec3 j(-g.x(), -g.y(), -(g.x() * (-sn * p.x() - cs * p.y()) + g.y() * (cs * p.x() - sn * p.y())));
        *h += j * j.transpose();
        *b += j * r;
      }
    }
    return c;
  };
  Pose2 pose = start;
  Mat3 h;
  Vec3 b;
  double c = evaluate(pose, &h, &b);
  double lambda = 1e-3;
  int it = 0;
  for (; it < cfg_.gn_iterations; ++it) {
    Mat3 damped = h;
    damped.diagonal() *= 1.0 + lambda;
    damped.diagonal().array() += 1e-9;
    const Vec3 step = -damped.ldlt().solve(b);
    if (!step.allFinite()) break;
    const Pose2 trial{pose.x + step.x(), pose.y + step.y(), normalize_angle(pose.theta + step.z())};
    Mat3 th;
    Vec3 tb;
    const double tc = evaluate(trial, &th, &tb);
    if (tc < c) {
      pose = trial;
      c = tc;
      h = th;
      b = tb;
      lambda = std::max(1e-6, lambda * 0.3);
      if (step.head<2>().norm() < 1e-5 && std::abs(step.z()) < 1e-5) {
        ++it;
        break;
      }
    } else {
      lambda *= 10;
      if (lambda > 1e4) break;
    }
  }
  *cost = c;
  *iterations = it;
  return pose;
}

MatchResult ScanMatcher::match(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& guess) {
  MatchResult out;
  out.pose = guess;
  if (points.size() < 3) return out;

  // Points for the correlative stages: at least decimate_m apart along the scan.
  sparse_.clear();
  const double d2 = cfg_.decimate_m * cfg_.decimate_m;
  for (const Vec2& p : points) {
    if (sparse_.empty() || (p - sparse_[sparse_.size() - 1]).squaredNorm() >= d2) {
      if (!sparse_.push_back(p)) break;
    }
  }

  // Coarse correlative search: angles so a point at step_range_m moves one coarse cell.
  const double res_c = grid.config().resolution_m * grid.config().coarse_factor;
  const SearchShape shape = search_shape(grid.config(), cfg_);
  const double coarse_step = shape.coarse_step;
  const int na = shape.coarse_angles;
  const int nt = shape.coarse_shifts;
  const Vec2 origin = grid.origin();
  kept_ = 0;
  const std::size_t n = sparse_.size();
  for (int a = -na; a <= na; ++a) {
    const double th = guess.theta + a * coarse_step;
    const double cs = std::cos(th), sn = std::sin(th);
    index_points(cs, sn, guess.translation() - origin, res_c);
    for (int ty = -nt; ty <= nt; ++ty) {
      for (int tx = -nt; tx <= nt; ++tx) {
        double s = 0;
        for (std::size_t i = 0; i < n; ++i) s += static_cast<double>(grid.coarse_cell(cell_x_[i] + tx, cell_y_[i] + ty));
        keep({th, guess.x + tx * res_c, guess.y + ty * res_c, s});
      }
    }
  }
  if (kept_ == 0) return out;
  out.coarse_score = best_[0].score / static_cast<double>(sparse_.size());

  Candidate best;
  for (int k = 0; k < kept_; ++k) {
    const Candidate f = search_fine(grid, best_[static_cast<std::size_t>(k)], shape);
    if (f.score > best.score) best = f;
  }

  double cost = 0;
  const Pose2 p = refine(grid, points, {best.x, best.y, normalize_angle(best.theta)}, &cost, &out.iterations);
  finish(grid, points, p, cost, &out);
  return out;
}

double ScanMatcher::log_likelihood(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& pose) const {
  // Robust: a point with no surface near it costs log(eps), not -inf.
  constexpr double kEps = 0.05;
  const double cs = std::cos(pose.theta), sn = std::sin(pose.theta);
  double l = 0;
  for (const Vec2& p : points) {
    const Vec2 q(cs * p.x() - sn * p.y() + pose.x, sn * p.x() + cs * p.y() + pose.y);
    l += std::log(kEps + (1.0 - kEps) * grid.sample(q, nullptr));
  }
  return l;
}

void ScanMatcher::finish(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& pose, double cost,
                         MatchResult* out) const {
  out->pose = pose;
  const auto np = static_cast<double>(points.size());
  out->score = 1.0 - std::sqrt(cost / np);  // 1 - RMS residual

  // Covariance: the inverse curvature of the scan's negative log-likelihood at the match,
  // by central differences one cell / one fine angular step wide (the squared-residual
  // Gauss-Newton information vanishes exactly at a peak, so it cannot be used). Points
  // are not independent (neighbouring beams see one wall), so the result is inflated by
  // `covariance_scale`; eigenvalues are clamped so a direction the field does not pin
  // (a corridor) gets a large variance instead of a blow-up.
  const double res = grid.config().resolution_m;
  const Vec3 h(res, res, res / cfg_.step_range_m);
  Mat3 hess;
  const double f0 = -log_likelihood(grid, points, pose);
  auto f = [&](const Vec3& d) {
    return -log_likelihood(grid, points, {pose.x + d.x(), pose.y + d.y(), pose.theta + d.z()});
  };
  for (int i = 0; i < 3; ++i) {
    Vec3 ei = Vec3::Zero();
    ei(i) = h(i);
    hess(i, i) = (f(ei) - 2 * f0 + f(-ei)) / (h(i) * h(i));
    for (int j = i + 1; j < 3; ++j) {
      Vec3 ej = Vec3::Zero();
      ej(j) = h(j);
      hess(i, j) = hess(j, i) = (f(ei + ej) - f(ei - ej) - f(ej - ei) + f(-ei - ej)) / (4 * h(i) * h(j));
    }
  }
  Eigen::SelfAdjointEigenSolver<Mat3> eig(hess);
  const Vec3 ev = eig.eigenvalues().cwiseMax(1e-3);  // at most ~30 m / 30 rad of standard deviation
  Mat3 cov = cfg_.covariance_scale * (eig.eigenvectors() * ev.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose());
  cov(0, 0) += cfg_.sigma_floor_xy_m * cfg_.sigma_floor_xy_m;
  cov(1, 1) += cfg_.sigma_floor_xy_m * cfg_.sigma_floor_xy_m;
  cov(2, 2) += cfg_.sigma_floor_theta_rad * cfg_.sigma_floor_theta_rad;
  out->covariance = 0.5 * (cov + cov.transpose());
  out->ok = out->score >= cfg_.min_score && out->covariance.allFinite();
}

}  // namespace cairn::localmap
