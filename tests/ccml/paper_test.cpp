// The cooperative-CML paper reproduced: the theorems and bounds of §III and §V on
// the simulation of §VI (Tables I-III).
#include <gtest/gtest.h>

#include "basestation/ccml/bounds.hpp"
#include "tools/paper_sim/paper_sim.hpp"

namespace cairn::ccml {
namespace {

double min_det_after(const PaperRun& r, double t0) {
  double m = 1e300;
  for (const auto& s : r.samples) {
    if (s.t >= t0) m = std::min(m, s.det_vehicle_a);
  }
  return m;
}

TEST(PaperScenario1, SingleVehicleStaysAtItsInitialUncertainty) {  // Theorem III.3
  const PaperRun r = run_paper_simulation(PaperScenario::table(1, 1));
  const double det0 = 0.2 * 0.2 * 0.2 * 0.2;
  for (const auto& s : r.samples) ASSERT_NEAR(s.det_vehicle_a / det0, 1.0, 1e-6) << "t=" << s.t;
  // ... and the features converge to it (Theorem III.2): never better than the vehicle.
  EXPECT_NEAR(r.samples.back().det_feature_1 / det0, 1.0, 0.02);
}

TEST(PaperScenario1, CooperativeConvergesToTheEq5Bound) {  // Theorem V.2
  const PaperRun r = run_paper_simulation(PaperScenario::table(1, 2));
  const Mat2 p0 = Vec2(0.04, 0.04).asDiagonal();
  const Mat2 both[] = {p0, p0};
  const double bound = cooperative_bound(both).determinant();
  EXPECT_NEAR(r.bound_det, bound, 1e-15);
  const double final_det = r.samples.back().det_vehicle_a;
  EXPECT_NEAR(final_det / bound, 1.0, 0.05) << "det(P_AA) at 300 s " << final_det << " vs bound " << bound;
  // Monotone (no process noise: Theorem III.1) and never meaningfully below the bound.
  for (std::size_t k = 1; k < r.samples.size(); ++k) {
    ASSERT_LE(r.samples[k].det_vehicle_a, r.samples[k - 1].det_vehicle_a * (1 + 1e-9));
  }
  EXPECT_GT(min_det_after(r, 0) / bound, 0.98);
  // Theorem III.2: feature 1 converges to the vehicle's uncertainty.
  EXPECT_NEAR(r.samples.back().det_feature_1 / final_det, 1.0, 0.05);
  // Both vehicles reach the same covariance.
  EXPECT_NEAR(r.vehicle_covs[1].determinant() / final_det, 1.0, 0.05);
  EXPECT_GT(r.min_eigenvalue, -1e-12);  // PSD (heading variance is exactly 0 here)
  EXPECT_LT(r.max_asymmetry, 1e-12);
}

TEST(PaperScenario1, ThirdVehicleJoiningFollowsEq7) {
  PaperScenario s = PaperScenario::table(1, 2);
  s.third_vehicle_at = 150.0;
  s.join_sigma = Vec3(0.3, 0.3, 0.0);
  const PaperRun r = run_paper_simulation(s);
  const Mat2 pa = Vec2(0.04, 0.04).asDiagonal(), pc = Vec2(0.09, 0.09).asDiagonal();
  const Mat2 three[] = {pa, pa, pc};
  const double bound = cooperative_bound(three).determinant();
  EXPECT_NEAR(r.bound_det / bound, 1.0, 1e-9);
  EXPECT_NEAR(r.samples.back().det_vehicle_a / bound, 1.0, 0.05);
  // Before C joins, A sits at the two-vehicle bound.
  const Mat2 two[] = {pa, pa};
  const auto before = std::find_if(r.samples.begin(), r.samples.end(), [](const PaperSample& x) { return x.t >= 149.8; });
  EXPECT_NEAR(before->det_vehicle_a / cooperative_bound(two).determinant(), 1.0, 0.05);
}

TEST(PaperScenario2, ProcessNoiseKeepsTheTeamAboveTheBound) {
  const PaperRun coop = run_paper_simulation(PaperScenario::table(2, 2));
  const PaperRun single = run_paper_simulation(PaperScenario::table(2, 1));
  for (const auto& s : coop.samples) ASSERT_GT(s.det_vehicle_a, coop.bound_det) << "t=" << s.t;
  // Cooperation still helps: the team's vehicle A is better than A alone, on average over the run.
  double c = 0, a = 0;
  for (std::size_t k = 0; k < coop.samples.size(); ++k) {
    c += coop.samples[k].det_vehicle_a;
    a += single.samples[k].det_vehicle_a;
  }
  EXPECT_LT(c, a);
  EXPECT_GT(coop.min_eigenvalue, 0.0);
}

TEST(VehiclesNeeded, Eq10SolvedAndEq11AsPrinted) {
  const Mat2 p0 = Vec2(0.04, 0.04).asDiagonal();
  const Mat2 want = p0 / 4.0;  // four identical vehicles give P0/4
  EXPECT_EQ(vehicles_needed(want, p0), 4);
  EXPECT_EQ(vehicles_needed(p0 / 4.5, p0), 5);
  EXPECT_EQ(vehicles_needed(p0 * 2.0, p0), 1);
  // The paper's eq. 11 gives n^2 for 2-D positions (det(nP⁻¹) = n² det(P⁻¹)).
  EXPECT_NEAR(vehicles_needed_paper_eq11(want, p0), 16.0, 1e-9);
}

}  // namespace
}  // namespace cairn::ccml
