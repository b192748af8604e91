// cairn-bench-scan-mrpt: Cairn's scan matcher beside MRPT's 2D ICP (mrpt::slam::CICP,
// Debian libmrpt-dev) on the same Carmen scan pairs and the same perturbed initial
// guesses, in one run: registration error and time per match, and the Cairn/MRPT ratios.
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/slam/CICP.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "tools/eval/scan_eval.hpp"

using namespace cairn;
using namespace cairn::eval;
using SteadyClock = std::chrono::steady_clock;

namespace {

double ms_between(SteadyClock::time_point a, SteadyClock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::vector<PairOutcome> run_mrpt_pairs(const CarmenLog& log, const std::vector<PairCase>& cases,
                                        const ScanEvalOptions& o, const mrpt::slam::CICP::TConfigParams& params) {
  mrpt::slam::CICP icp(params);
  std::vector<Vec2> ref, cur;
  std::vector<PairOutcome> out;
  for (const PairCase& c : cases) {
    carmen_points(log.scans[c.ref], o.map.min_range_m, o.map.max_range_m, &ref);
    carmen_points(log.scans[c.ref + 1], o.map.min_range_m, o.map.max_range_m, &cur);
    const auto t0 = SteadyClock::now();
    mrpt::maps::CSimplePointsMap m1, m2;
    for (const Vec2& p : ref) m1.insertPointFast(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
    for (const Vec2& p : cur) m2.insertPointFast(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
    m1.mark_as_modified();
    m2.mark_as_modified();
    const auto t1 = SteadyClock::now();
    mrpt::slam::CICP::TReturnInfo info;
    const auto pdf = icp.Align(&m1, &m2, mrpt::poses::CPose2D(c.initial.x, c.initial.y, c.initial.theta), info);
    const auto t2 = SteadyClock::now();
    const mrpt::poses::CPose2D mean = pdf->getMeanVal();
    PairOutcome r;
    r.estimate = {mean.x(), mean.y(), mean.phi()};
    r.match_ms = ms_between(t1, t2);
    r.total_ms = ms_between(t0, t2);
    out.push_back(r);
  }
  return out;
}

nlohmann::json summary_json(const PairSummary& s) {
  return {{"median_xy_m", s.err_xy_m.median},   {"p95_xy_m", s.err_xy_m.p95},
          {"median_theta_deg", s.err_theta_deg.median}, {"p95_theta_deg", s.err_theta_deg.p95},
          {"success_rate", s.success_rate},     {"median_total_ms", s.total_ms.median},
          {"p99_total_ms", s.total_ms.p99}};
}

void print_row(const char* name, const PairSummary& s) {
  std::printf("%-26s %9.4f %9.4f %9.3f %9.3f %8.1f %9.3f %9.3f\n", name, s.err_xy_m.median, s.err_xy_m.p95,
              s.err_theta_deg.median, s.err_theta_deg.p95, 100 * s.success_rate, s.total_ms.median, s.total_ms.p99);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-bench-scan-mrpt: Cairn's scan matcher vs MRPT ICP on the same Carmen scan pairs"};
  std::vector<std::string> logs;
  ScanEvalOptions o;
  app.add_option("logs", logs, "Carmen logs (.log or .log.gz)")->required()->check(CLI::ExistingFile);
  app.add_option("--max-pairs", o.max_pairs, "pairs per log (0 = all)");
  app.add_option("--seed", o.seed, "perturbation seed");
  std::string json_path;
  app.add_option("--json", json_path, "also write the results as JSON to this file");
  CLI11_PARSE(app, argc, argv);

  // MRPT as a user would run it for scan-to-scan: classic point-to-point ICP with its
  // default thresholds, and the Levenberg-Marquardt variant; covariance skipped (our
  // covariance is cheap; theirs is by finite differences), so only alignment is timed.
  mrpt::slam::CICP::TConfigParams classic;
  classic.maxIterations = 100;
  classic.skip_cov_calculation = true;
  classic.corresponding_points_decimation = 1;
  mrpt::slam::CICP::TConfigParams lm = classic;
  lm.ICP_algorithm = mrpt::slam::icpLevenbergMarquardt;

  nlohmann::json all = nlohmann::json::array();
  int worse = 0;
  for (const std::string& path : logs) {
    const CarmenLog log = read_carmen_log(path);
    const auto cases = make_pair_cases(log, o);
    std::printf("\n%s: %zu pairs, guess noise %.2f m / %.1f deg (seed %llu)\n", path.c_str(), cases.size(),
                o.sigma_xy_m, o.sigma_theta_deg, static_cast<unsigned long long>(o.seed));
    std::printf("%-26s %9s %9s %9s %9s %8s %9s %9s\n", "matcher", "med m", "p95 m", "med deg", "p95 deg", "ok %",
                "med ms", "p99 ms");
    const PairSummary cairn_s = summarize_pairs(cases, run_cairn_pairs(log, cases, o), o);
    print_row("cairn (correlative+GN)", cairn_s);
    const PairSummary mc = summarize_pairs(cases, run_mrpt_pairs(log, cases, o, classic), o);
    print_row("mrpt CICP classic", mc);
    const PairSummary ml = summarize_pairs(cases, run_mrpt_pairs(log, cases, o, lm), o);
    print_row("mrpt CICP LM", ml);
    for (const auto& [name, m] : {std::pair{"classic", &mc}, std::pair{"lm", &ml}}) {
      std::printf("ratio cairn/mrpt-%-8s error xy %.2f, error theta %.2f, success %.2f, time %.3f (mrpt %.1fx slower)\n",
                  name, cairn_s.err_xy_m.median / m->err_xy_m.median,
                  cairn_s.err_theta_deg.median / m->err_theta_deg.median, cairn_s.success_rate / m->success_rate,
                  cairn_s.total_ms.median / m->total_ms.median, m->total_ms.median / cairn_s.total_ms.median);
    }
    if (cairn_s.success_rate < mc.success_rate) ++worse;
    all.push_back({{"log", path}, {"pairs", cases.size()}, {"cairn", summary_json(cairn_s)},
                   {"mrpt_classic", summary_json(mc)}, {"mrpt_lm", summary_json(ml)}});
  }
  if (!json_path.empty()) {
    std::FILE* f = std::fopen(json_path.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", json_path.c_str());
      return 1;
    }
    std::fprintf(f, "%s\n", all.dump(2).c_str());
    std::fclose(f);
  }
  return 0;
}
