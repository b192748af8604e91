#include "firmware/localmap/likelihood_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cairn::localmap {

int kernel_radius_cells(const GridConfig& c) {
  const double r = 3.0 * c.sigma_m / c.resolution_m;
  return static_cast<int>(std::ceil(r - 1e-9));
}

const char* validate(const GridConfig& c) {
  if (!(c.resolution_m > 0.001 && c.resolution_m <= 1.0)) return "resolution_m must be in (0.001, 1] m";
  if (c.size_cells < 16 || c.size_cells > 8192) return "size_cells must be in [16, 8192]";
  if (!(c.sigma_m > 0 && c.sigma_m <= 1.0)) return "sigma_m must be in (0, 1] m";
  if (c.coarse_factor < 2 || c.coarse_factor > 16) return "coarse_factor must be in [2, 16]";
  if (c.size_cells % c.coarse_factor != 0) return "size_cells must be a multiple of coarse_factor";
  if (kernel_radius_cells(c) > LikelihoodGrid::kMaxRadius) return "sigma_m must be at most 8 cells (kernel radius 3 sigma <= 24 cells)";
  return nullptr;
}

LikelihoodGrid::LikelihoodGrid(const GridConfig& cfg) : cfg_(cfg) {
  if (const char* e = validate(cfg)) throw std::invalid_argument(std::string("likelihood grid: ") + e);
  n_ = cfg.size_cells;
  nc_ = n_ / cfg.coarse_factor;
  inv_res_ = 1.0 / cfg.resolution_m;
  inv_two_sigma2_ = 1.0 / (2.0 * cfg.sigma_m * cfg.sigma_m);
  radius_ = kernel_radius_cells(cfg);
  const auto taps = static_cast<std::size_t>(2 * radius_ + 1);
  wx_ = std::make_unique<float[]>(taps);
  wy_ = std::make_unique<float[]>(taps);
  const auto nn = static_cast<std::size_t>(n_);
  const auto nc = static_cast<std::size_t>(nc_);
  fine_ = std::make_unique<float[]>(nn * nn);
  coarse_ = std::make_unique<float[]>(nc * nc);
  std::fill_n(fine_.get(), nn * nn, 0.0f);
  std::fill_n(coarse_.get(), nc * nc, 0.0f);
  reset(Vec2::Zero());
}

void LikelihoodGrid::reset(const Vec2& centre) {
  origin_ = centre - Vec2::Constant(0.5 * n_ * cfg_.resolution_m);
  // Clear only what the last build touched (a scan covers a fraction of the window).
  if (x_hi_ >= x_lo_) {
    const auto nn = static_cast<std::size_t>(n_), nc = static_cast<std::size_t>(nc_);
    const auto w = static_cast<std::size_t>(x_hi_ - x_lo_ + 1);
    for (int y = y_lo_; y <= y_hi_; ++y)
      std::fill_n(fine_.get() + static_cast<std::size_t>(y) * nn + static_cast<std::size_t>(x_lo_), w, 0.0f);
    const int f = cfg_.coarse_factor;
    const auto cw = static_cast<std::size_t>(x_hi_ / f - x_lo_ / f + 1);
    for (int y = y_lo_ / f; y <= y_hi_ / f; ++y)
      std::fill_n(coarse_.get() + static_cast<std::size_t>(y) * nc + static_cast<std::size_t>(x_lo_ / f), cw, 0.0f);
  }
  x_lo_ = y_lo_ = n_;
  x_hi_ = y_hi_ = -1;
}

void LikelihoodGrid::add_point(const Vec2& p) {
  // Cell centres sit at origin + (i + 0.5) * res; the kernel uses the exact distance to p.
  const double gx = (p.x() - origin_.x()) * inv_res_ - 0.5, gy = (p.y() - origin_.y()) * inv_res_ - 0.5;
  if (!(gx >= 0 && gy >= 0 && gx < n_ - 1 && gy < n_ - 1)) {
    ++outside_;
    return;
  }
  ++added_;
  const int cx = static_cast<int>(std::lround(gx)), cy = static_cast<int>(std::lround(gy));
  const int x0 = std::max(0, cx - radius_), x1 = std::min(n_ - 1, cx + radius_);
  const int y0 = std::max(0, cy - radius_), y1 = std::min(n_ - 1, cy + radius_);
  x_lo_ = std::min(x_lo_, x0);
  x_hi_ = std::max(x_hi_, x1);
  y_lo_ = std::min(y_lo_, y0);
  y_hi_ = std::max(y_hi_, y1);
  // The Gaussian is separable: exp(-(dx²+dy²)k) = exp(-dx²k)·exp(-dy²k).
  const double k = cfg_.resolution_m * cfg_.resolution_m * inv_two_sigma2_;
  // x1 - x0 <= 2 * radius_, so the weights fit the buffers sized from the same radius.
  float* wx = wx_.get();
  float* wy = wy_.get();
  for (int x = x0; x <= x1; ++x) wx[x - x0] = static_cast<float>(std::exp(-(x - gx) * (x - gx) * k));
  for (int y = y0; y <= y1; ++y) wy[y - y0] = static_cast<float>(std::exp(-(y - gy) * (y - gy) * k));
  for (int y = y0; y <= y1; ++y) {
    float* row = fine_.get() + static_cast<std::size_t>(y) * static_cast<std::size_t>(n_);
    const float vy = wy[y - y0];
    for (int x = x0; x <= x1; ++x) row[x] = std::max(row[x], vy * wx[x - x0]);
  }
}

void LikelihoodGrid::add_surface(std::span<const Vec2> points, double max_gap) {
  const double step = 0.5 * cfg_.resolution_m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    add_point(points[i]);
    if (i + 1 == points.size()) break;
    const Vec2 d = points[i + 1] - points[i];
    const double len = d.norm();
    if (!(len < max_gap) || len <= step) continue;
    const int n = static_cast<int>(len / step);  // bounded: max_gap / step points at most
    for (int k = 1; k < n; ++k) add_point(points[i] + d * (k / static_cast<double>(n)));
  }
}

void LikelihoodGrid::finish() {
  const int f = cfg_.coarse_factor;
  if (x_hi_ < x_lo_) return;
  for (int cy = y_lo_ / f; cy <= y_hi_ / f; ++cy) {
    for (int cx = x_lo_ / f; cx <= x_hi_ / f; ++cx) {
      float m = 0.0f;
      for (int y = cy * f; y < (cy + 1) * f; ++y) {
        const float* row = fine_.get() + static_cast<std::size_t>(y) * static_cast<std::size_t>(n_);
        for (int x = cx * f; x < (cx + 1) * f; ++x) m = std::max(m, row[x]);
      }
      coarse_[static_cast<std::size_t>(cy) * static_cast<std::size_t>(nc_) + static_cast<std::size_t>(cx)] = m;
    }
  }
}

double LikelihoodGrid::sample(const Vec2& p, Vec2* gradient) const {
  const double gx = (p.x() - origin_.x()) * inv_res_ - 0.5, gy = (p.y() - origin_.y()) * inv_res_ - 0.5;
  if (!(gx >= 0 && gy >= 0 && gx < n_ - 1 && gy < n_ - 1)) {
    if (gradient) gradient->setZero();
    return 0.0;
  }
  const int x = static_cast<int>(gx), y = static_cast<int>(gy);
  const double fx = gx - x, fy = gy - y;
  const double v00 = static_cast<double>(cell(x, y)), v10 = static_cast<double>(cell(x + 1, y));
  const double v01 = static_cast<double>(cell(x, y + 1)), v11 = static_cast<double>(cell(x + 1, y + 1));
  if (gradient) {
    gradient->x() = ((v10 - v00) * (1 - fy) + (v11 - v01) * fy) * inv_res_;
    gradient->y() = ((v01 - v00) * (1 - fx) + (v11 - v10) * fx) * inv_res_;
  }
  return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy;
}

}  // namespace cairn::localmap
