// cairn-eval mrclam: dead reckoning, single-robot EKF-SLAM and cooperative CML on a
// UTIAS MRCLAM dataset, with landmark association by the barcode labels and by JCBB; with
// JCBB also the base station's own Fusion fed as robots would feed it (base-fusion).
#include <algorithm>
#include <filesystem>
#include <optional>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "tools/datasets/mrclam.hpp"
#include "tools/datasets/mrclam_base.hpp"
#include "tools/datasets/mrclam_calibration.hpp"
#include "tools/eval/commands.hpp"

namespace cairn::eval {

using nlohmann::json;
using namespace cairn::ccml;

namespace {

json to_json(const MrclamResult& r) {
  json robots = json::array();
  for (const auto& x : r.robots) {
    json j = {{"robot", x.robot}, {"localized", x.localized}, {"localized_at_s", x.localized_at}};
    if (x.rmse_xy >= 0) {
      j["position_rmse_m"] = x.rmse_xy;
      j["nees_mean"] = x.nees_mean;
      j["samples"] = x.samples;
    }
    robots.push_back(j);
  }
  json mism = json::array();
  for (const auto& [l, g] : r.label_mismatches) mism.push_back({{"label", l}, {"lands_on", g}});
  json j = {{"mode", r.mode},
            {"association", r.association},
            {"robots", robots},
            {"features", r.features},
            {"measurements_used", r.measurements_used},
            {"measurements_rejected", r.measurements_rejected},
            {"association_errors", r.association_errors_known ? json(r.association_errors) : json(nullptr)},
            {"unknown_barcodes_dropped", r.unknown_barcodes_dropped},
            {"duration_s", r.duration_s},
            {"runtime_s", r.runtime_s}};
  if (r.rmse_xy_mean >= 0) j["position_rmse_mean_m"] = r.rmse_xy_mean;
  if (r.landmark_rmse_aligned >= 0) {
    j["landmarks"] = {{"matched", r.landmarks_matched},
                      {"rmse_unaligned_m", r.landmark_rmse_unaligned},
                      {"rmse_aligned_m", r.landmark_rmse_aligned},
                      {"alignment", {{"x", r.alignment.x}, {"y", r.alignment.y}, {"theta", r.alignment.theta}}},
                      {"rmse_label_free_m", r.landmark_rmse_label_free},
                      {"label_mismatches", mism}};
  }
  return j;
}

json noise_json(const MrclamNoiseFit& f, const std::string& dataset) {
  return {{"calibrated_on", dataset},
          {"window_s", f.until_s},
          {"landmark_sightings", f.measurements},
          {"range_sigma_m", f.range_sigma},
          {"bearing_sigma_rad", f.bearing_sigma},
          {"range_median_m", f.range_median},
          {"bearing_median_rad", f.bearing_median},
          {"odometry_windows", f.odometry_windows},
          {"odom_v_rel", f.odom_v_rel},
          {"odom_v_rate", f.odom_v_rate},
          {"odom_w_rel", f.odom_w_rel},
          {"odom_w_rate", f.odom_w_rate},
          {"odometry_factor", f.odometry_factor},
          {"calibration_nees", f.calibration_nees}};
}

}  // namespace

int mrclam(const MrclamCmdOptions& o) {
  std::cerr << "mrclam: reading " << o.dir << "...\n";
  const MrclamData data = load_mrclam(o.dir);
  std::cerr << "mrclam: " << data.robots.size() << " robots, " << data.landmarks.size() << " landmarks, "
            << data.unknown_barcodes_dropped << " measurements of unknown barcodes dropped, robot ground truth "
            << (data.has_robot_groundtruth() ? "present" : "MISSING (robots 2-5 join by relocation)") << "\n";
  struct Run {
    MrclamOptions::Mode mode;
    MrclamOptions::Association assoc;
  };
  std::vector<Run> runs = {{MrclamOptions::Mode::kDeadReckoning, MrclamOptions::Association::kLabels}};
  for (auto mode : {MrclamOptions::Mode::kSingleRobot, MrclamOptions::Mode::kCooperative}) {
    if (o.association != "jcbb") runs.push_back({mode, MrclamOptions::Association::kLabels});
    if (o.association != "labels") runs.push_back({mode, MrclamOptions::Association::kJcbb});
  }
  json out = {{"dataset", o.dir}, {"runs", json::array()}};
  std::optional<MrclamNoiseFit> fit;
  double score_from = o.score_from;
  if (!o.calibrate_on.empty()) {
    const bool same = std::filesystem::equivalent(o.calibrate_on, o.dir);
    std::cerr << "mrclam: fitting the noise model on the first " << o.calibrate_until << " s of " << o.calibrate_on << "...\n";
    fit = same ? calibrate_mrclam(data, o.calibrate_until) : calibrate_mrclam(load_mrclam(o.calibrate_on), o.calibrate_until);
    // Held out: poses in the calibration window are not scored.
    if (same) score_from = std::max(score_from, o.calibrate_until);
    out["noise"] = noise_json(*fit, o.calibrate_on);
  }
  out["poses_scored_from_s"] = score_from;
  std::vector<MrclamResult> results;
  for (const Run& run : runs) {
    MrclamOptions opt;
    opt.mode = run.mode;
    opt.association = run.assoc;
    opt.duration = o.duration;
    opt.iterations = o.iterations;
    if (fit) apply_noise(*fit, &opt);
    opt.score_from = score_from;
    std::cerr << "mrclam: " << mode_name(run.mode) << " (" << association_name(run.assoc) << ")...\n";
    results.push_back(run_mrclam(data, opt));
    out["runs"].push_back(to_json(results.back()));
  }
  if (o.association != "labels") {  // the base's own Fusion: what a live base does with these robots
    MrclamOptions opt;
    opt.duration = o.duration;
    opt.iterations = o.iterations;
    if (fit) apply_noise(*fit, &opt);
    opt.score_from = score_from;
    std::cerr << "mrclam: base-fusion (the base station's Fusion, jcbb)...\n";
    results.push_back(run_mrclam_base(data, opt));
    out["runs"].push_back(to_json(results.back()));
  }
  // Cooperative vs single-robot, labels, robot position RMSE.
  const MrclamResult* single = nullptr;
  const MrclamResult* coop = nullptr;
  for (const auto& r : results) {
    if (r.association != "labels") continue;
    if (r.mode == "single-robot-slam") single = &r;
    if (r.mode == "cooperative-cml") coop = &r;
  }
  if (single && coop && single->rmse_xy_mean > 0 && coop->rmse_xy_mean >= 0) {
    out["cooperative_improvement_over_single"] = 1.0 - coop->rmse_xy_mean / single->rmse_xy_mean;
  }
  if (o.json) {
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  if (fit) {
    std::printf("noise fitted on the first %.0f s of %s (%zu sightings, %zu odometry windows): range %.3f m, bearing %.4f rad "
                "(medians %+.3f m, %+.4f rad); odometry x %.3f/step + %.3f m/sqrt(s), heading %.3f/step + %.3f rad/sqrt(s), "
                "times %.2f for a calibration NEES of %.2f%s\n",
                fit->until_s, o.calibrate_on.c_str(), fit->measurements, fit->odometry_windows, fit->range_sigma,
                fit->bearing_sigma, fit->range_median, fit->bearing_median, fit->odom_v_rel, fit->odom_v_rate, fit->odom_w_rel,
                fit->odom_w_rate, fit->odometry_factor, fit->calibration_nees, "");
  }
  if (score_from > 0) {
    std::printf("robot poses (rmse, NEES) scored from %.0f s after the start; the other columns cover the whole run\n",
                score_from);
  }
  std::printf("%-18s %-7s %10s %9s %9s %9s %9s %8s %8s\n", "estimator", "assoc", "rmse (m)", "NEES", "features",
              "lm rmse", "lm free", "assoc err", "time (s)");
  for (const auto& r : results) {
    double nees = 0;
    int n = 0;
    for (const auto& x : r.robots) {
      if (x.nees_mean >= 0) {
        nees += x.nees_mean;
        ++n;
      }
    }
    const std::string errors = r.association_errors_known ? std::to_string(r.association_errors) : "-";
    std::printf("%-18s %-7s %10.3f %9.1f %9zu %9.3f %9.3f %8s %8.2f\n", r.mode.c_str(), r.association.c_str(),
                r.rmse_xy_mean, n ? nees / n : -1.0, r.features, r.landmark_rmse_aligned, r.landmark_rmse_label_free,
                errors.c_str(), r.runtime_s);
  }
  if (out.contains("cooperative_improvement_over_single")) {
    std::printf("cooperative CML vs single-robot EKF-SLAM (labels): %.0f%% lower robot position RMSE\n",
                100 * out["cooperative_improvement_over_single"].get<double>());
  }
  // A mutual swap under the label-free fit (a lands on b and b on a) points at the data's labels.
  for (const auto& r : results) {
    if (r.association != "labels") continue;
    for (const auto& pair : r.label_mismatches) {
      const auto l = pair.first, g = pair.second;  // named copies: clang cannot capture bindings
      const bool mutual = std::any_of(r.label_mismatches.begin(), r.label_mismatches.end(),
                                      [&](const auto& m) { return m.first == g && m.second == l; });
      if (mutual && l < g) {
        std::printf("note: %s: landmarks %d and %d are swapped relative to the ground-truth file (label-free fit)\n",
                    r.mode.c_str(), l, g);
      }
    }
  }
  std::printf("(-1 = not available: robot ground truth missing. Alignment: least-squares SE(2) of the estimated map "
              "onto the ground-truth landmarks; 'lm free' = label-free nearest-neighbour ICP; base-fusion sees no labels, so its "
              "landmarks are matched label-free and its association errors are not known: '-'.)\n");
  return 0;
}

}  // namespace cairn::eval
