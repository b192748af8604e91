// Calibrates the local mapper's work model (firmware/localmap/work_estimate.hpp): times
// match() and the field's build on synthetic scans of a room with decimation and gap
// filling off (so the model's worst-case counts are the exact counts), fits the cost of
// each operation in ns, and prints the table to paste into kCalibratedCosts. Then checks
// the model on the default configuration: the estimate must not be below the measurement.
//   build/release/tests/bench/cairn-calibrate-localmap [repetitions]
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <vector>

#include "firmware/localmap/work_estimate.hpp"

using namespace cairn;
using namespace cairn::localmap;

namespace {

struct Segment {
  Vec2 a, b;
};

// A 12 × 8 m room with a box and an L (as in localmap_test); 361 beams over 180°.
std::vector<Vec2> scan(const Pose2& pose, std::mt19937_64* rng) {
  static const std::vector<Segment> walls = {
      {{0, 0}, {12, 0}}, {{12, 0}, {12, 8}}, {{12, 8}, {0, 8}},   {{0, 8}, {0, 0}},    {{4, 2}, {5, 2}},
      {{5, 2}, {5, 3.5}}, {{5, 3.5}, {4, 3.5}}, {{4, 3.5}, {4, 2}}, {{8, 5}, {10, 5}}, {{8, 5}, {8, 6.5}}};
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Vec2> pts;
  for (int i = 0; i < 361; ++i) {
    const double a = -std::numbers::pi / 2 + i * std::numbers::pi / 360;
    const Vec2 d(std::cos(pose.theta + a), std::sin(pose.theta + a));
    double best = 1e9;
    for (const Segment& s : walls) {
      const Vec2 e = s.b - s.a, w = s.a - pose.translation();
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::abs(den) < 1e-12) continue;
      const double t = (w.x() * e.y() - w.y() * e.x()) / den, u = (w.x() * d.y() - w.y() * d.x()) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (best > 14) continue;
    const double r = best + noise(*rng);
    pts.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return pts;
}

int g_reps = 31;

// Median wall time of f() in ns.
template <typename F>
double median_ns(F f) {
  std::vector<double> t;
  for (int i = 0; i < g_reps; ++i) {
    const auto a = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - a).count());
  }
  std::nth_element(t.begin(), t.begin() + static_cast<long>(t.size() / 2), t.end());
  return t[t.size() / 2];
}

const std::vector<Pose2> kPoses = {{3, 5, 0.2}, {3.3, 5.1, 0.3}, {3.6, 5.2, 0.4}, {3.9, 5.3, 0.5}, {2.5, 4.5, 0.1},
                                   {2.2, 4.2, 0.0}, {2.0, 4.0, -0.2}, {2.3, 3.0, -0.4}, {2.6, 2.5, -0.6}, {3.0, 2.0, -0.8}};

// Keyframes in the frame of kPoses[0] (the local frame is the first pose's).
std::vector<std::vector<Vec2>> keyframes(std::mt19937_64* rng) {
  std::vector<std::vector<Vec2>> out;
  for (const Pose2& p : kPoses) {
    const Pose2 rel = between(kPoses[0], p);
    std::vector<Vec2> s = scan(p, rng);
    for (Vec2& q : s) q = transform_point(rel, q);
    out.push_back(std::move(s));
  }
  return out;
}

void build(LikelihoodGrid* g, const std::vector<std::vector<Vec2>>& kf, double gap) {
  g->reset(Vec2::Zero());
  for (const auto& s : kf) g->add_surface(s, gap);
  g->finish();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) g_reps = std::max(3, std::atoi(argv[1]));
  std::mt19937_64 rng(1);
  const auto kf = keyframes(&rng);
  const std::vector<Vec2> cur = scan(compose(kPoses[0], Pose2{0.1, -0.05, 0.03}), &rng);
  const int beams = static_cast<int>(cur.size());

  // Matching: T = taps × a + index × b + evaluations × c, fitted over search shapes that
  // weigh the three differently (rows scaled by 1/T: a relative fit).
  struct Shape {
    double xy, theta;
    int candidates, gn;
  };
  const Shape shapes[] = {{0.4, 0.35, 2, 12}, {1.2, 0.35, 2, 12}, {0.0, 0.0, 1, 12}, {0.0, 1.2, 1, 12},
                          {0.0, 0.0, 1, 0},   {0.8, 0.7, 4, 30}};
  LocalMapConfig base;
  base.match.decimate_m = 0;
  base.surface_gap_m = 0;
  LikelihoodGrid field(base.grid);
  build(&field, {kf[0]}, 0.0);
  Eigen::MatrixXd A(std::size(shapes), 3);
  Eigen::VectorXd ones = Eigen::VectorXd::Ones(std::size(shapes));
  std::printf("match() of %d points, decimation off:\n", beams);
  int row = 0;
  for (const Shape& s : shapes) {
    LocalMapConfig c = base;
    c.match.window_xy_m = s.xy;
    c.match.window_theta_rad = s.theta;
    c.match.candidates = s.candidates;
    c.match.gn_iterations = s.gn;
    ScanMatcher m(c.match, static_cast<std::size_t>(c.max_points));
    MatchResult r;
    const double t = median_ns([&] { r = m.match(field, cur, Pose2{0.12, -0.02, 0.02}); });
    const WorkEstimate w = estimate_work(c, beams);
    const double evals = (r.iterations + 1 + 19.0) * beams;  // the iterations it did, not the limit
    A.row(row++) << w.search_taps / t, w.index_ops / t, evals / t;
    std::printf("  window %.1f m %.2f rad, %d candidates, %2d GN: %8.3f ms  (%.3g taps, %.3g index, %.3g evals)\n", s.xy,
                s.theta, s.candidates, s.gn, t * 1e-6, w.search_taps, w.index_ops, evals);
  }
  const Eigen::Vector3d match_costs = A.colPivHouseholderQr().solve(ones);
  const Eigen::VectorXd fit = A * match_costs;
  std::printf("  fit: worst row off by %.0f %%\n", 100 * (fit - ones).cwiseAbs().maxCoeff());

  // Rebuild: stamps at two kernel radii (the slope is the tap), cells on a full window.
  double stamp_taps[2], stamp_t[2], stamps = 0;
  for (int i = 0; i < 2; ++i) {
    GridConfig g = base.grid;
    g.sigma_m = i == 0 ? 0.05 : 0.10;
    LikelihoodGrid grid(g);
    const int r = kernel_radius_cells(g);
    stamp_t[i] = median_ns([&] { build(&grid, kf, 0.0); });
    stamps = static_cast<double>(grid.points_added()) / g_reps;  // points_added() accumulates
    stamp_taps[i] = stamps * (2 * r + 1) * (2 * r + 1);
  }
  // Same points at both radii: the difference is taps alone; what the taps do not explain
  // at radius 3 is the per-point part (the weights' exp).
  const double stamp_tap_ns = (stamp_t[1] - stamp_t[0]) / (stamp_taps[1] - stamp_taps[0]);
  const double stamp_ns = (stamp_t[0] - stamp_taps[0] * stamp_tap_ns) / stamps;
  LikelihoodGrid full(base.grid);
  const double half = 0.5 * base.grid.size_cells * base.grid.resolution_m - 0.1;
  const double cells_t = median_ns([&] {
    full.reset(Vec2::Zero());
    for (const Vec2& corner : {Vec2(-half, -half), Vec2(half, -half), Vec2(-half, half), Vec2(half, half)}) full.add_point(corner);
    full.finish();
  });
  const double cell_ns = cells_t / (static_cast<double>(base.grid.size_cells) * base.grid.size_cells);
  std::printf("rebuild: %.0f stamps, r 3: %.3f ms, r 6: %.3f ms; %dx%d cells cleared and pooled: %.3f ms\n", stamps,
              stamp_t[0] * 1e-6, stamp_t[1] * 1e-6, base.grid.size_cells, base.grid.size_cells, cells_t * 1e-6);

  // The request copy (async): keyframes × max_points points.
  std::vector<Vec2> from(static_cast<std::size_t>(base.keyframes * base.max_points), Vec2(1, 2)), to(from.size());
  const double copy_ns = median_ns([&] {
                           std::copy(from.begin(), from.end(), to.begin());
                           asm volatile("" ::"r"(to.data()) : "memory");
                         }) /
                         static_cast<double>(from.size());

  const WorkCosts k{match_costs(0), match_costs(1), match_costs(2), copy_ns, stamp_ns, stamp_tap_ns, cell_ns};
  std::printf("\nWorkCosts (ns): search_tap %.3f, index %.3f, point_eval %.3f, copy %.3f, stamp %.3f, stamp_tap %.3f, "
              "cell %.3f\n",
              k.search_tap_ns, k.index_ns, k.point_eval_ns, k.copy_ns, k.stamp_ns, k.stamp_tap_ns, k.cell_ns);

  // The model against the default configuration (decimation and gap filling on).
  LocalMapConfig def;
  ScanMatcher m(def.match, static_cast<std::size_t>(def.max_points));
  const double t_match = median_ns([&] { (void)m.match(field, cur, Pose2{0.12, -0.02, 0.02}); });
  LikelihoodGrid grid(def.grid);
  const double t_rebuild = median_ns([&] { build(&grid, kf, def.surface_gap_m); });
  const WorkEstimate calibrated = estimate_work(def, beams, k), shipped = estimate_work(def, beams);
  std::printf("default configuration, %d beams: match %.3f ms measured, %.3f ms estimated (%.3f with kCalibratedCosts); "
              "rebuild %.3f ms measured, %.3f ms estimated (%.3f)\n",
              beams, t_match * 1e-6, calibrated.match_ms, shipped.match_ms, t_rebuild * 1e-6, calibrated.rebuild_ms,
              shipped.rebuild_ms);
  return 0;
}
