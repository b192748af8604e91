// cairn-eval scans: scan-pair registration and local-mapper drift on a Carmen log.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "tools/eval/commands.hpp"
#include "tools/eval/scan_eval.hpp"

namespace cairn::eval {

namespace {
nlohmann::json to_json(const Distribution& d) {
  return {{"median", d.median}, {"p95", d.p95}, {"p99", d.p99}, {"max", d.max}};
}
}  // namespace

nlohmann::json pair_summary_json(const PairSummary& s) {
  return {{"pairs", s.pairs},
          {"success_rate", s.success_rate},
          {"mean_nees", s.mean_nees},
          {"within_95_pct", s.within_95_pct},
          {"error_xy_m", to_json(s.err_xy_m)},
          {"error_theta_deg", to_json(s.err_theta_deg)},
          {"initial_xy_m", to_json(s.initial_xy_m)},
          {"initial_theta_deg", to_json(s.initial_theta_deg)},
          {"match_ms", to_json(s.match_ms)},
          {"total_ms", to_json(s.total_ms)}};
}

int scans(const ScansCmdOptions& so) {
  ScanEvalOptions o;
  o.sigma_xy_m = so.sigma_xy;
  o.sigma_theta_deg = so.sigma_theta_deg;
  o.seed = so.seed;
  o.max_pairs = so.max_pairs;
  const CarmenLog log = read_carmen_log(so.log);
  if (!so.json) {
    std::printf("%s: %zu scans, %zu odometry records, %llu malformed lines\n", so.log.c_str(), log.scans.size(),
                log.odom.size(), static_cast<unsigned long long>(log.bad));
    for (const auto& e : log.errors) std::printf("  %s\n", e.c_str());
  }
  if (log.scans.size() < 2) {
    std::fprintf(stderr, "cairn-eval scans: %s has fewer than two FLASER scans\n", so.log.c_str());
    return 1;
  }
  const auto cases = make_pair_cases(log, o);
  if (!so.json) std::printf("registering %zu consecutive pairs (guess: reference + N(0, %.2f m, %.1f deg), seed %llu)...\n",
                            cases.size(), o.sigma_xy_m, o.sigma_theta_deg, static_cast<unsigned long long>(o.seed));
  const PairSummary ps = summarize_pairs(cases, run_cairn_pairs(log, cases, o), o);
  nlohmann::json j = {{"log", so.log}, {"scans", log.scans.size()}, {"malformed_lines", log.bad},
                      {"pairs", pair_summary_json(ps)}};
  if (!so.json) {
    std::printf("  initial error      median %.3f m %.2f deg\n", ps.initial_xy_m.median, ps.initial_theta_deg.median);
    std::printf("  registration error median %.4f m %.3f deg, p95 %.4f m %.3f deg\n", ps.err_xy_m.median,
                ps.err_theta_deg.median, ps.err_xy_m.p95, ps.err_theta_deg.p95);
    std::printf("  success (<= %.2f m, %.1f deg) %.1f %%\n", o.success_xy_m, o.success_theta_deg, 100 * ps.success_rate);
    std::printf("  covariance: mean NEES %.2f (3 = consistent), %.1f %% inside the 95%% ellipsoid\n", ps.mean_nees,
                ps.within_95_pct);
    std::printf("  time per match     median %.3f ms, p99 %.3f ms (with building the field: %.3f / %.3f ms)\n",
                ps.match_ms.median, ps.match_ms.p99, ps.total_ms.median, ps.total_ms.p99);
  }
  if (!so.no_mapper) {
    if (!so.json) std::printf("running the local mapper over the log with perturbed odometry...\n");
    const DriftSummary d = run_local_mapper(log, o);
    j["local_mapper"] = {{"path_m", d.path_m},
                         {"final_error_m", d.final_error_m},
                         {"final_drift_pct", d.final_drift_pct},
                         {"segment_drift_pct", d.segment_drift_pct},
                         {"odometry_final_drift_pct", d.odom_final_drift_pct},
                         {"odometry_segment_drift_pct", d.odom_segment_drift_pct},
                         {"scans", d.scans},
                         {"matched", d.matched},
                         {"rejected", d.rejected},
                         {"update_ms", to_json(d.update_ms)}};
    if (!so.json) {
      std::printf("  path %.1f m; %llu scans, %llu matched, %llu rejected\n", d.path_m,
                  static_cast<unsigned long long>(d.scans), static_cast<unsigned long long>(d.matched),
                  static_cast<unsigned long long>(d.rejected));
      std::printf("  drift over 10 m segments %.2f %% (odometry alone %.2f %%); end point %.2f m = %.2f %% (odometry %.2f %%)\n",
                  d.segment_drift_pct, d.odom_segment_drift_pct, d.final_error_m, d.final_drift_pct,
                  d.odom_final_drift_pct);
      std::printf("  update time median %.3f ms, p99 %.3f ms, max %.3f ms\n", d.update_ms.median, d.update_ms.p99,
                  d.update_ms.max);
    }
  }
  if (so.json) std::printf("%s\n", j.dump(2).c_str());
  return 0;
}

}  // namespace cairn::eval
