// cairn-eval ccml-paper: the cooperative-CML paper's figures and a JSON summary.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "basestation/ccml/bounds.hpp"
#include "tools/eval/commands.hpp"
#include "tools/eval/plot.hpp"
#include "tools/paper_sim/paper_sim.hpp"

namespace cairn::eval {

using nlohmann::json;
using namespace cairn::ccml;

namespace {

json run_summary(const PaperRun& r) {
  const auto& last = r.samples.back();
  return {{"vehicles", r.scenario.vehicles},
          {"det_vehicle_a_initial", r.samples.front().det_vehicle_a},
          {"det_vehicle_a_final", last.det_vehicle_a},
          {"det_feature_1_final", last.det_feature_1},
          {"bound_det", r.bound_det},
          {"final_over_bound", last.det_vehicle_a / r.bound_det},
          {"min_eigenvalue", r.min_eigenvalue},
          {"max_asymmetry", r.max_asymmetry}};
}

}  // namespace

int ccml_paper(const CcmlPaperOptions& o) {
  std::filesystem::create_directories(o.out_dir);
  PaperScenario single_s = PaperScenario::table(o.scenario, 1), coop_s = PaperScenario::table(o.scenario, 2);
  single_s.seed = coop_s.seed = o.seed;
  single_s.update_iterations = coop_s.update_iterations = o.iterations;
  std::cerr << "ccml-paper: scenario " << o.scenario << ", 300 s at 5 Hz, single vehicle and two vehicles...\n";
  const PaperRun single = run_paper_simulation(single_s);
  const PaperRun coop = run_paper_simulation(coop_s);

  // The bound of eq. 5 for the team (initial covariances of A and B).
  Figure det{"Scenario " + std::to_string(o.scenario) + ": vehicle A position error determinant", "time (s)",
             "det(P_AA) (m^4)", true, false, {}, {}};
  Series s_single{"single-vehicle CML", {}, {}, "lines lw 2"}, s_coop{"cooperative CML", {}, {}, "lines lw 2"},
      s_bound{"eq. 5 bound", {}, {}, "lines dt 2 lw 2 lc rgb \"black\""};
  Figure feat{"Scenario " + std::to_string(o.scenario) + ": feature 1 error determinant (cooperative)", "time (s)",
              "det (m^4)", true, false, {}, {}};
  Series f1{"feature 1", {}, {}}, va{"vehicle A", {}, {}};
  for (std::size_t k = 0; k < coop.samples.size(); ++k) {
    const double t = coop.samples[k].t;
    s_single.x.push_back(t);
    s_single.y.push_back(single.samples[k].det_vehicle_a);
    s_coop.x.push_back(t);
    s_coop.y.push_back(coop.samples[k].det_vehicle_a);
    s_bound.x.push_back(t);
    s_bound.y.push_back(coop.bound_det);
    if (coop.samples[k].det_feature_1 > 0) {
      f1.x.push_back(t);
      f1.y.push_back(coop.samples[k].det_feature_1);
    }
    va.x.push_back(t);
    va.y.push_back(coop.samples[k].det_vehicle_a);
  }
  det.series = {s_single, s_coop, s_bound};
  feat.series = {va, f1};

  Figure ell{"Scenario " + std::to_string(o.scenario) + ": 3-sigma ellipses at 300 s (cooperative)", "x (m)", "y (m)",
             false, true, {}, {}};
  Series true_pts{"true vehicles", {}, {}, "points pt 7 ps 1.5"}, true_f{"true features", {}, {}, "points pt 5 ps 1.5"};
  Series est_pts{"estimates", {}, {}, "points pt 2 ps 1.5"}, ellipses{"3-sigma", {}, {}};
  for (std::size_t v = 0; v < coop.true_vehicles.size(); ++v) {
    true_pts.x.push_back(coop.true_vehicles[v].x);
    true_pts.y.push_back(coop.true_vehicles[v].y);
    est_pts.x.push_back(coop.est_vehicles[v].x);
    est_pts.y.push_back(coop.est_vehicles[v].y);
    const Mat2& c = coop.vehicle_covs[v];
    ellipse_points(coop.est_vehicles[v].x, coop.est_vehicles[v].y, c(0, 0), c(0, 1), c(1, 1), 3, &ellipses.x, &ellipses.y);
  }
  for (std::size_t j = 0; j < coop.true_features.size(); ++j) {
    true_f.x.push_back(coop.true_features[j].x());
    true_f.y.push_back(coop.true_features[j].y());
    est_pts.x.push_back(coop.est_features[j].x());
    est_pts.y.push_back(coop.est_features[j].y());
    const Mat2& c = coop.feature_covs[j];
    ellipse_points(coop.est_features[j].x(), coop.est_features[j].y(), c(0, 0), c(0, 1), c(1, 1), 3, &ellipses.x,
                   &ellipses.y);
  }
  ell.series = {true_pts, true_f, est_pts, ellipses};

  bool rendered = render_png(det, o.out_dir, "det_vehicle_a");
  rendered &= render_png(feat, o.out_dir, "det_feature_1");
  rendered &= render_png(ell, o.out_dir, "ellipses");

  json j = {{"scenario", o.scenario},
            {"seed", o.seed},
            {"update_iterations", o.iterations},
            {"layout", "A on a 12 m square, B on a 6 m square, features at (+-8,0),(0,+-8); see docs/ccml.md"},
            {"single_vehicle", run_summary(single)},
            {"cooperative", run_summary(coop)},
            {"figures", {"det_vehicle_a.png", "det_feature_1.png", "ellipses.png"}},
            {"figures_rendered", rendered}};
  std::ofstream(o.out_dir + "/summary.json") << j.dump(2) << "\n";
  if (o.json) {
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << "scenario " << o.scenario << ": det(P_AA) initial " << coop.samples.front().det_vehicle_a << " m^4\n"
              << "  single vehicle at 300 s: " << single.samples.back().det_vehicle_a << "\n"
              << "  cooperative at 300 s:    " << coop.samples.back().det_vehicle_a << "  (bound " << coop.bound_det
              << ", ratio " << coop.samples.back().det_vehicle_a / coop.bound_det << ")\n"
              << "  feature 1 at 300 s:      " << coop.samples.back().det_feature_1 << "\n"
              << "figures and summary.json in " << o.out_dir << "\n";
  }
  return 0;
}

int vehicles_needed_cmd(double initial_sigma, double desired_sigma, bool as_json) {
  const Mat2 p0 = Vec2(initial_sigma * initial_sigma, initial_sigma * initial_sigma).asDiagonal();
  const Mat2 pd = Vec2(desired_sigma * desired_sigma, desired_sigma * desired_sigma).asDiagonal();
  const int n = vehicles_needed(pd, p0);
  const double paper = vehicles_needed_paper_eq11(pd, p0);
  if (as_json) {
    std::cout << json{{"initial_sigma", initial_sigma}, {"desired_sigma", desired_sigma}, {"vehicles", n},
                      {"paper_eq11", paper}}
                     .dump(2)
              << "\n";
  } else {
    std::cout << "vehicles needed for " << desired_sigma << " m map accuracy from " << initial_sigma
              << " m initial vehicle accuracy: " << n << "\n"
              << "(eq. 11 as printed gives " << paper << ", which is n^2 for 2-D positions; see docs/ccml.md)\n";
  }
  return 0;
}

}  // namespace cairn::eval
