// cairn-eval: Cairn's evaluations on simulated and real data.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "tools/eval/commands.hpp"

int main(int argc, char** argv) {
  using namespace cairn::eval;
  CLI::App app{"cairn-eval: evaluates Cairn's estimators on the papers' simulations and on real datasets."};
  app.require_subcommand(1);

  CcmlPaperOptions paper;
  auto* cp = app.add_subcommand("ccml-paper",
                                "Reproduce the cooperative-CML paper (Fenwick, Newman, Leonard): its figures as PNG and a "
                                "JSON summary");
  cp->add_option("--scenario", paper.scenario, "1 (no process noise) or 2 (process noise)")->check(CLI::IsMember({1, 2}));
  cp->add_option("--out", paper.out_dir, "output directory for the figures and summary.json");
  cp->add_option("--seed", paper.seed, "random seed");
  cp->add_option("--iterations", paper.iterations, "EKF update iterations (1 = EKF, >1 = iterated EKF)")
      ->check(CLI::Range(1, 50));
  cp->add_flag("--json", paper.json, "print the summary as JSON");

  double initial = 0.2, desired = 0.1;
  bool vn_json = false;
  auto* vn = app.add_subcommand("vehicles-needed", "Eq. 10/11: how many vehicles reach a desired map accuracy");
  vn->add_option("--initial-sigma", initial, "initial vehicle position std (m)")->check(CLI::PositiveNumber);
  vn->add_option("--desired-sigma", desired, "desired map position std (m)")->check(CLI::PositiveNumber);
  vn->add_flag("--json", vn_json, "print JSON");

  MrclamCmdOptions mr;
  auto* mc = app.add_subcommand("mrclam",
                                "UTIAS MRCLAM dataset: dead reckoning, single-robot EKF-SLAM and cooperative CML vs ground truth");
  mc->add_option("dir", mr.dir, "dataset directory (e.g. data/mrclam/MRCLAM_Dataset6; files plain or .gz)")->required()->check(CLI::ExistingDirectory);
  mc->add_option("--association", mr.association, "landmark data association: labels, jcbb or both (jcbb and both add base-fusion: the base station's own Fusion)")
      ->check(CLI::IsMember({"labels", "jcbb", "both"}));
  mc->add_option("--duration", mr.duration, "use only the first S seconds (0 = all)")->check(CLI::NonNegativeNumber);
  mc->add_option("--iterations", mr.iterations, "EKF update iterations (1 = EKF)")->check(CLI::Range(1, 50));
  mc->add_option("--calibrate-on", mr.calibrate_on,
                 "fit the noise model on this dataset's ground truth (docs/ccml.md); when it is DIR itself, "
                 "results are scored only after the calibration window")
      ->check(CLI::ExistingDirectory);
  mc->add_option("--calibrate-until", mr.calibrate_until, "calibration window: the first S seconds (default 300)")
      ->check(CLI::PositiveNumber);
  mc->add_option("--score-from", mr.score_from,
                 "score robot poses (RMSE, NEES) only from S seconds after the start (default 0; with --calibrate-on DIR "
                 "itself, the calibration window)")
      ->check(CLI::NonNegativeNumber);
  mc->add_flag("--json", mr.json, "print JSON");

  ScansCmdOptions sc;
  auto* sn = app.add_subcommand("scans",
                                "Carmen laser log: register consecutive scan pairs from perturbed reference poses, then run "
                                "the local mapper with perturbed odometry; errors against the log's reference poses");
  sn->add_option("log", sc.log, "Carmen log, plain or .gz (e.g. data/radish-corrected-carmen/intel-corrected.log.gz)")
      ->required()
      ->check(CLI::ExistingFile);
  sn->add_option("--sigma-xy", sc.sigma_xy, "initial-guess noise per axis (m)")->check(CLI::NonNegativeNumber);
  sn->add_option("--sigma-theta-deg", sc.sigma_theta_deg, "initial-guess heading noise (deg)")->check(CLI::NonNegativeNumber);
  sn->add_option("--seed", sc.seed, "random seed for the perturbations");
  sn->add_option("--max-pairs", sc.max_pairs, "use only the first N pairs (0 = all)");
  sn->add_flag("--no-mapper", sc.no_mapper, "skip the local-mapper drift run");
  sn->add_flag("--json", sc.json, "print JSON");

  ExploreCmdOptions ex;
  auto* xp = app.add_subcommand("explore",
                                "The exploration seed's experiments on cairn-sim's fleet: runs x robot counts of one world, "
                                "times to 50/90/95/100 % coverage, completed and failed runs, plots (docs/explore.md)");
  xp->add_option("--world", ex.world, "world file (the HIL format, docs/hil.md)")->required()->check(CLI::ExistingFile);
  xp->add_option("--robots", ex.robots, "robot counts, e.g. 1,2,3")->delimiter(',')->capture_default_str()
      ->check(CLI::Range(1, 50));
  xp->add_option("--runs", ex.runs, "runs per robot count (run k: seed + k)")->capture_default_str()->check(CLI::Range(1, 1000));
  xp->add_option("--mode", ex.mode,
                 "coordinated (the seed's discount), uncoordinated (each robot its own best item), or both "
                 "(uncoordinated for counts above 1)")
      ->capture_default_str()
      ->check(CLI::IsMember({"coordinated", "uncoordinated", "both"}));
  xp->add_option("--seed", ex.seed, "seed of run 0")->capture_default_str();
  xp->add_flag("--random-maps", ex.random_maps,
               "run k on another map of the world's kind: its 'random' line's seed + k (the seed's environments D, E)");
  xp->add_flag("--shared-world", ex.shared_world,
               "all robots in one world: they see each other, their protective fields stop them for each other and "
               "they can collide (default: a world per robot, robots pass through each other)");
  xp->add_option("--duration", ex.duration, "simulated seconds per run at most")->capture_default_str()
      ->check(CLI::Range(10.0, 1e5));
  xp->add_option("--cells-per-metre", ex.cells_per_metre,
                 "the exchange rate, cells of expected gain per metre of path, of the base's task allocator and of the "
                 "robots' bids (default: [explore] cells_per_metre and gain_per_metre; for tuning on held-out worlds, "
                 "scripts/explore-tune.sh)")
      ->check(CLI::Range(0.0, 1e4));
  xp->add_option("--jobs", ex.jobs, "runs at once (default: one per core)")->check(CLI::Range(1, 64));
  xp->add_option("--out", ex.out_dir, "output directory (default explore-WORLD)");
  xp->add_flag("--verbose", ex.verbose, "print the simulated robots' and base's warnings too");
  xp->add_flag("--json", ex.json, "print the summary as JSON");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*cp) return ccml_paper(paper);
    if (*vn) return vehicles_needed_cmd(initial, desired, vn_json);
    if (*mc) return mrclam(mr);
    if (*sn) return scans(sc);
    if (*xp) return explore(ex);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cairn-eval: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
