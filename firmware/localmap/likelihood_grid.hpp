// A fixed-size likelihood field for scan matching: a square window of cells around a
// centre, each holding how likely a laser return is there (1 on a surface seen before,
// falling off as a Gaussian of the distance to the nearest one). A max-pooled coarse
// level (one cell per `coarse_factor`² fine cells) bounds the fine level from above, so a
// coarse correlative search never misses a block the fine level would score higher.
// All memory is reserved at construction; reset/add_point/finish never allocate.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "common/se2.hpp"

namespace cairn::localmap {

struct GridConfig {
  double resolution_m = 0.05;  // fine cell edge
  int size_cells = 512;        // the window is size_cells² fine cells (25.6 m at 5 cm)
  double sigma_m = 0.05;       // smoothing of the field (the laser's range noise + cell size)
  int coarse_factor = 4;       // coarse cell = coarse_factor × fine cell
};

/// The Gaussian kernel's radius in cells: 3 sigma, rounded up. The one formula for both
/// validate() and the grid (they disagreed once). A ratio within 1e-9 of a whole number
/// counts as that number: 3 × 0.05 / 0.05 is 3.0000000000000004 in doubles, which a plain
/// ceil made 4 cells (81 taps instead of 49).
int kernel_radius_cells(const GridConfig& c);

/// Checks a grid configuration; returns nullptr or what is wrong.
const char* validate(const GridConfig& c);

class LikelihoodGrid {
 public:
  static constexpr int kMaxRadius = 24;  // largest kernel_radius_cells() validate() accepts

  explicit LikelihoodGrid(const GridConfig& cfg);

  /// Empties the field and centres the window on `centre` (a frame's coordinates).
  void reset(const Vec2& centre);
  /// Adds a surface point (same frame as the centre). Points outside the window are counted.
  void add_point(const Vec2& p);
  /// Adds a scan's points in beam order; neighbours closer than `max_gap` are joined by
  /// points every half cell, so the field follows the surface between sparse far returns.
  void add_surface(std::span<const Vec2> points, double max_gap);
  /// Rebuilds the coarse level; call after the last add_point and before matching.
  void finish();

  const GridConfig& config() const { return cfg_; }
  int size() const { return n_; }
  int coarse_size() const { return nc_; }
  int kernel_radius() const { return radius_; }  // kernel_radius_cells(config())
  Vec2 origin() const { return origin_; }  // corner of cell (0, 0)
  Vec2 centre() const { return origin_ + Vec2::Constant(0.5 * n_ * cfg_.resolution_m); }
  std::uint64_t points_outside() const { return outside_; }
  std::uint64_t points_added() const { return added_; }

  /// Fine cell value, 0 outside the window.
  float cell(int ix, int iy) const {
    return (static_cast<unsigned>(ix) < static_cast<unsigned>(n_) && static_cast<unsigned>(iy) < static_cast<unsigned>(n_))
               ? fine_[static_cast<std::size_t>(iy) * static_cast<std::size_t>(n_) + static_cast<std::size_t>(ix)]
               : 0.0f;
  }
  /// Fine cell value by a row-major index known to be inside (the matcher's inner loop).
  float cell_unchecked(std::size_t index) const { return fine_[index]; }
  /// Coarse cell value (max over its fine cells), 0 outside.
  float coarse_cell(int ix, int iy) const {
    return (static_cast<unsigned>(ix) < static_cast<unsigned>(nc_) && static_cast<unsigned>(iy) < static_cast<unsigned>(nc_))
               ? coarse_[static_cast<std::size_t>(iy) * static_cast<std::size_t>(nc_) + static_cast<std::size_t>(ix)]
               : 0.0f;
  }
  /// Bilinear interpolation of the fine level at p with its gradient (per metre).
  double sample(const Vec2& p, Vec2* gradient) const;

 private:
  GridConfig cfg_;
  int n_ = 0, nc_ = 0, radius_ = 0;
  double inv_res_ = 0, inv_two_sigma2_ = 0;
  Vec2 origin_ = Vec2::Zero();
  std::unique_ptr<float[]> fine_, coarse_;
  std::unique_ptr<float[]> wx_, wy_;  // add_point's separable kernel weights, 2 × radius + 1 each
  // Cells touched since the last reset (inclusive bounds): reset and finish work only there.
  int x_lo_ = 0, x_hi_ = -1, y_lo_ = 0, y_hi_ = -1;
  std::uint64_t outside_ = 0, added_ = 0;
};

}  // namespace cairn::localmap
