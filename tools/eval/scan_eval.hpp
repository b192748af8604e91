// Scan-matching evaluation on a Carmen log: consecutive scan pairs registered from a
// perturbed reference relative pose, and the full local mapper run with perturbed
// odometry. Matcher-agnostic, so a peer (MRPT ICP) runs on exactly the same cases.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "common/se2.hpp"
#include "firmware/localmap/local_mapper.hpp"
#include "tools/datasets/carmen_log.hpp"

namespace cairn::eval {

struct ScanEvalOptions {
  double sigma_xy_m = 0.10;       // initial-guess perturbation (per axis)
  double sigma_theta_deg = 5.0;
  std::uint64_t seed = 1;
  std::size_t max_pairs = 0;      // 0 = every consecutive pair
  double success_xy_m = 0.10;     // a registration within these is a success
  double success_theta_deg = 2.0;
  // Local-mapper run: odometry noise per step, proportional to the motion.
  double odom_noise_xy = 0.10;          // × distance
  double odom_noise_theta = 0.10;       // × |rotation|
  double odom_noise_theta_per_m = 0.05; // rad per m travelled
  localmap::LocalMapConfig map;
};

/// Scan points (robot frame = laser frame) with ranges inside the map's limits.
void carmen_points(const CarmenScan& s, double min_range, double max_range, std::vector<Vec2>* out);

struct PairCase {
  std::size_t ref = 0;  // scan index; the second scan is ref + 1
  Pose2 truth;          // reference pose of ref+1 in ref's frame
  Pose2 initial;        // truth perturbed
};
std::vector<PairCase> make_pair_cases(const CarmenLog& log, const ScanEvalOptions& o);

struct PairOutcome {
  Pose2 estimate;
  double match_ms = 0;  // the registration alone
  double total_ms = 0;  // including building the reference (field, kd-tree, ...)
  bool has_covariance = false;
  Mat3 covariance = Mat3::Identity();
};

struct Distribution {
  double median = 0, p95 = 0, p99 = 0, max = 0;
};
Distribution distribution(std::vector<double> v);

struct PairSummary {
  std::size_t pairs = 0;
  Distribution err_xy_m, err_theta_deg, initial_xy_m, initial_theta_deg, match_ms, total_ms;
  double success_rate = 0;
  double mean_nees = 0;        // over successful matches with a covariance (3 = consistent)
  double within_95_pct = 0;    // share of those whose error is inside the 95% ellipsoid
};
PairSummary summarize_pairs(const std::vector<PairCase>& cases, const std::vector<PairOutcome>& out,
                            const ScanEvalOptions& o);

/// Cairn's matcher on every case (reference field built from the first scan of a pair).
std::vector<PairOutcome> run_cairn_pairs(const CarmenLog& log, const std::vector<PairCase>& cases,
                                         const ScanEvalOptions& o);

struct DriftSummary {
  double path_m = 0;
  double final_error_m = 0, final_drift_pct = 0;      // end-point error / path length
  double segment_drift_pct = 0;                       // mean over 10 m segments
  double odom_final_drift_pct = 0, odom_segment_drift_pct = 0;  // the perturbed odometry alone
  std::uint64_t scans = 0, matched = 0, rejected = 0;
  Distribution update_ms;
};
/// Runs the local mapper over the log with perturbed odometry; drift against the reference.
DriftSummary run_local_mapper(const CarmenLog& log, const ScanEvalOptions& o);

}  // namespace cairn::eval
