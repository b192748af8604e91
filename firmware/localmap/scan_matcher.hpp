// Registers a scan (points in the robot frame) against a likelihood field, starting from
// a guess (odometry): a correlative search over a window around the guess on the coarse
// level, the best few candidates searched again on the fine level, then Gauss-Newton on
// the bilinearly interpolated field (the seed paper's gradient ascent on a differentiable
// likelihood, made robust by the correlative stage). The covariance comes from the
// curvature of the scan's log-likelihood at the match, inflated and floored. Pure: no I/O; every
// buffer is reserved at construction for `max_points`, so match() never allocates.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "common/fixed_vector.hpp"
#include "common/se2.hpp"
#include "firmware/localmap/likelihood_grid.hpp"

namespace cairn::localmap {

struct MatchConfig {
  double window_xy_m = 0.4;         // correlative search: ± around the guess
  double window_theta_rad = 0.35;   // ± around the guess (20°)
  double step_range_m = 6.0;        // angular steps chosen so a point this far moves ~one cell
  double decimate_m = 0.08;         // points for the correlative stages: at least this far apart
  int candidates = 2;               // coarse candidates searched again at the fine level
  int gn_iterations = 12;
  double min_score = 0.35;          // mean likelihood at the match below this: not matched
  double covariance_scale = 6.0;    // inflation for correlated beams (calibrated on Intel/ACES)
  double sigma_floor_xy_m = 0.005;  // covariance floors
  double sigma_floor_theta_rad = 0.001;
};

const char* validate(const MatchConfig& c);

/// The correlative search's extent: the one formula match() searches with and the work
/// estimate (work_estimate.hpp) counts with.
struct SearchShape {
  double coarse_step = 0;  // rad: a point step_range_m away moves one coarse cell
  int coarse_angles = 0;   // ± coarse steps around the guess
  int coarse_shifts = 0;   // ± coarse cells around the guess, in x and in y
  double fine_step = 0;    // rad: a point step_range_m away moves one fine cell
  int fine_angles = 0;     // ± fine steps around a coarse candidate
  int fine_shifts = 0;     // ± fine cells around a coarse candidate (half a coarse cell)
};
SearchShape search_shape(const GridConfig& g, const MatchConfig& m);

struct MatchResult {
  Pose2 pose;
  Mat3 covariance = Mat3::Identity();
  double score = 0;         // 1 - RMS residual of the field over all points at `pose`, 0..1
  double coarse_score = 0;  // best correlative score (coarse level)
  int iterations = 0;
  bool ok = false;          // score >= min_score and the field constrained the pose
};

class ScanMatcher {
 public:
  ScanMatcher(const MatchConfig& cfg, std::size_t max_points);

  MatchResult match(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& guess);
  const MatchConfig& config() const { return cfg_; }

 private:
  struct Candidate {
    double theta = 0, x = 0, y = 0, score = -1;
  };
  void keep(const Candidate& c);
  void finish(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& pose, double cost,
              MatchResult* out) const;
  double log_likelihood(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& pose) const;
  void index_points(double cs, double sn, const Vec2& offset, double cell);
  Candidate search_fine(const LikelihoodGrid& grid, const Candidate& c, const SearchShape& shape);
  Pose2 refine(const LikelihoodGrid& grid, std::span<const Vec2> points, const Pose2& start, double* cost,
               int* iterations) const;

  MatchConfig cfg_;
  FixedVector<Vec2> sparse_;
  std::unique_ptr<int[]> cell_x_, cell_y_;  // the sparse points' cells at one angle
  std::array<Candidate, 8> best_{};
  int kept_ = 0;
};

}  // namespace cairn::localmap
