// cairn-fuzz-base: runs a cairn-base beside a normal simulated fleet and floods every topic
// the base reads with random and mutated samples, on loopback (docs/fuzz-base.md). The base
// must stay up, keep its state finite and its memory bounded, count what it refused, apply
// exactly the fleet's messages, and give the real robots the estimates the same fleet
// stream gets through the same fusion in process. Exit status 0 only if all of that holds.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "basestation/base_config.hpp"
#include "basestation/fusion.hpp"
#include "common/program.hpp"
#include "tools/fleet_stream/fleet_publisher.hpp"
#include "tools/fuzz_base/base_process.hpp"
#include "tools/fuzz_base/base_summary.hpp"
#include "tools/fuzz_base/fuzz_traffic.hpp"

using namespace cairn;
namespace fs = std::filesystem;

namespace {

struct Options {
  double seconds = 60;
  double rate = 2000;      // fuzz samples per second, all topics
  double fleet_rate = 20;  // fleet odometry steps per second (the stream's step is 0.1 s)
  int robots = 3;
  std::uint64_t seed = 1;
  int domain = -1;
  std::string base_bin;
  std::string work_dir;
  double tolerance_m = 0.05, tolerance_rad = 0.02;  // docs/fuzz-base.md: what the base's own message order gives
  double max_rss_growth_mib = 16;
  std::vector<std::string> topics;  // empty: all
  bool sweep_ids = false;
  int unknown_robots = 0;  // [unknown_robot] max_robots; 0 = not allowed (the default)
  bool check_estimates = true;
  bool json = false;
};

std::string base_config(const Options& o, const fleet_stream::FleetScenario& s, const fs::path& dir) {
  std::ostringstream c;
  c << "[base]\nname = \"fuzz-base\"\n"
    << "[dds]\nprofile = \"loopback\"\ndomain = " << o.domain << "\n"
    << "[fleet]\nstale_after_s = 3.0\ntable_period_s = 1.0\n"
    << "[fusion]\nstate_dir = \"" << (dir / "state").string() << "\"\nsnapshot_period_s = 5.0\n";
  for (int r = 0; r < o.robots; ++r) {
    const Pose2& p = s.starts[static_cast<std::size_t>(r)];
    c << "[[robot]]\nid = " << r + 1 << "\ninitial_pose = [" << p.x << ", " << p.y << ", " << p.theta << "]\n";
  }
  // With --unknown-robots, fake robots are let in (up to the cap) and reach joining,
  // restarts and relocation; else the configured fleet alone, as config/base.toml has it.
  if (o.unknown_robots > 0) c << "[unknown_robot]\nallow = true\nmax_robots = " << o.unknown_robots << "\n";
  // A small scan store (default 64 MiB) fills early: the memory that is left to grow is
  // what no configuration bounds.
  c << "[mapper]\nexport_dir = \"" << (dir / "map").string() << "\"\nstore_mib = 4\n"
    << "[explore]\nenabled = true\n";
  return c.str();
}

double rss_mib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  }
  return 0;
}

// The refusals a run must have produced, given what it fuzzed: proof that the samples
// reached the base (a writer that matched no reader would pass every other check).
std::vector<std::string> expected_refusals(const Options& o, const fuzz::FuzzTraffic& t) {
  std::vector<std::string> r;
  if (t.fuzzes(fuzz::Topic::kOdometry) || t.fuzzes(fuzz::Topic::kFeatures)) {
    r.insert(r.end(), {"non_finite", "out_of_bounds", "bad_covariance"});
    r.emplace_back(o.unknown_robots > 0 ? "robot_cap" : "unknown_robot");
  }
  if (t.fuzzes(fuzz::Topic::kFeatures)) r.insert(r.end(), {"malformed", "bad_marker"});
  return r;
}

int run(Options o) {
  if (o.domain < 0) o.domain = 150 + static_cast<int>(getpid() % 80);  // apart from the tests' domains
  const fs::path dir = o.work_dir.empty() ? fs::temp_directory_path() / ("cairn-fuzz-base-" + std::to_string(getpid())) : fs::path(o.work_dir);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const int steps = static_cast<int>(o.seconds * o.fleet_rate);
  const fleet_stream::FleetScenario scenario = fleet_stream::make_fleet_scenario(o.robots, steps);
  const std::string cfg_text = base_config(o, scenario, dir);
  std::ofstream(dir / "base.toml") << cfg_text;

  // The reference: the same stream through the same fusion, in process, without the fuzzer.
  const base::BaseConfig cfg = base::parse_base_config(cfg_text, "base.toml");
  base::Fusion reference(cfg.fusion);
  std::map<std::uint16_t, Pose2> last_local;  // each real robot's last local pose in the stream
  for (const auto& m : scenario.messages) {
    fleet_stream::feed(&reference, m);
    if (const auto* od = std::get_if<msg::OdometryIncrement>(&m)) last_local[od->robot_id] = od->local_pose;
  }

  fuzz::BaseProcess base(o.base_bin, (dir / "base.toml").string(), (dir / "base.log").string());
  if (!base.wait_for_text("fusion: state in", 20 * kNanosPerSecond)) {
    throw std::runtime_error("cairn-base did not start (log " + (dir / "base.log").string() + "):\n" + base.log());
  }

  dds::Participant pp(dds::loopback_profile(static_cast<std::uint32_t>(o.domain)));
  fleet_stream::FleetPublisher fleet(pp, o.robots, 4096);
  fuzz::MutatorConfig mc;
  mc.seed = o.seed;
  mc.sweep_ids = o.sweep_ids;
  for (int r = 1; r <= o.robots; ++r) mc.fleet.push_back(static_cast<std::uint16_t>(r));
  std::vector<fuzz::Topic> topics;
  for (const std::string& name : o.topics) {
    for (std::size_t t = 0; t < fuzz::kTopics; ++t) {
      if (name == fuzz::topic_name(static_cast<fuzz::Topic>(t))) topics.push_back(static_cast<fuzz::Topic>(t));
    }
  }
  fuzz::FuzzTraffic traffic(pp, mc, topics);
  dds::Topic<cairn_PoseCorrection> corr_topic(pp);
  dds::Reader<cairn_PoseCorrection> corr_reader(pp, corr_topic, dds::latched_qos(1));
  fleet.wait_for_base(5 * kNanosPerSecond);

  std::map<std::uint16_t, cairn_PoseCorrection> last_corr;
  auto take_corrections = [&] {
    corr_reader.take([&](const cairn_PoseCorrection& c, const dds_sample_info_t&) { last_corr[c.robot_id] = c; },
                     [](const cairn_PoseCorrection&, dds::InstanceEvent) {});
  };

  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  const Nanos end = start + seconds_to_nanos(o.seconds);
  const Nanos step_period = static_cast<Nanos>(1e9 / o.fleet_rate);
  std::size_t next_msg = 0;
  int fleet_steps = 0;
  std::vector<std::pair<double, double>> rss;  // (t s, MiB)
  Nanos next_rss = start, next_progress = start + 10 * kNanosPerSecond;
  bool base_died = false, interrupted = false;
  for (;;) {
    const Nanos now = clock.now();
    if (now >= end) break;
    if (shutdown_requested()) {
      interrupted = true;
      break;
    }
    // The fleet: every robot's messages of step k at start + k·period.
    while (next_msg < scenario.messages.size() && now >= start + static_cast<Nanos>(fleet_steps) * step_period) {
      const msg::OdometryIncrement* od = fleet.publish(scenario.messages[next_msg++]);
      if (od && od->robot_id == o.robots) ++fleet_steps;
    }
    // The fuzzer: catch up with rate × elapsed, at most 200 samples per turn.
    const auto due = static_cast<std::uint64_t>(o.rate * nanos_to_seconds(now - start));
    for (int k = 0; k < 200 && traffic.total() < due; ++k) traffic.send_one();
    take_corrections();
    if (now >= next_rss) {
      next_rss += 500 * kNanosPerMilli;
      if (!base.alive()) {
        base_died = true;
        break;
      }
      rss.emplace_back(nanos_to_seconds(now - start), rss_mib(base.pid()));
    }
    if (now >= next_progress) {  // stderr: the JSON on stdout stays clean
      next_progress += 10 * kNanosPerSecond;
      std::fprintf(stderr, "cairn-fuzz-base: %.0f / %.0f s, %llu fuzz samples, fleet step %d / %d, base RSS %.1f MiB\n",
                   nanos_to_seconds(now - start), o.seconds, static_cast<unsigned long long>(traffic.total()), fleet_steps,
                   steps, rss.empty() ? 0.0 : rss.back().second);
    }
    clock.sleep_until(now + kNanosPerMilli);
  }
  const double ran_s = nanos_to_seconds(clock.now() - start);
  // The rest of the fleet stream (a run cut short), then let the base apply it: each real
  // robot's correction must imply the stream's last local pose (its last odometry applied);
  // then one more second for the features that follow it (5 correction periods).
  while (next_msg < scenario.messages.size()) fleet.publish(scenario.messages[next_msg++]);
  bool caught_up = false;
  if (!base_died) {
    const Nanos deadline = clock.now() + 60 * kNanosPerSecond;
    while (!caught_up && clock.now() < deadline && base.alive()) {
      clock.sleep_until(clock.now() + 100 * kNanosPerMilli);
      take_corrections();
      caught_up = true;
      for (const auto& [id, local] : last_local) {
        const auto it = last_corr.find(id);
        if (it == last_corr.end()) {
          caught_up = false;
          continue;
        }
        const cairn_Pose2& a = it->second.local_to_global;
        const cairn_Pose2& g = it->second.global_pose;
        const Pose2 implied = compose(inverse(Pose2{a.x, a.y, a.theta}), Pose2{g.x, g.y, g.theta});
        caught_up = caught_up && std::hypot(implied.x - local.x, implied.y - local.y) < 1e-6 &&
                    std::abs(normalize_angle(implied.theta - local.theta)) < 1e-6;
      }
    }
    const Nanos more = clock.now() + kNanosPerSecond;
    while (caught_up && clock.now() < more) {
      clock.sleep_until(clock.now() + 100 * kNanosPerMilli);
      take_corrections();
    }
    base_died = !base.alive();
  }
  const fuzz::BaseProcess::Exit exit = base.stop(10 * kNanosPerSecond);
  const std::string log = base.log();

  // Verdicts.
  std::vector<std::string> failures;
  char b[256];
  if (interrupted) failures.emplace_back("interrupted (SIGINT/SIGTERM) after " + std::to_string(static_cast<int>(ran_s)) + " s");
  if (exit.kind != fuzz::BaseProcess::Exit::kExited || exit.code != 0 || base_died) failures.push_back("cairn-base " + exit.describe());
  if (!base_died && !caught_up) failures.emplace_back("the base did not apply the fleet's last odometry within 60 s of the end");
  const std::string final_line = fuzz::last_line_with(log, "final fusion:");
  const fuzz::FusionLine fl = fuzz::parse_fusion_line(final_line);
  if (!fl.parsed) {
    failures.emplace_back("no final fusion line in the base's log");
  } else {
    if (!fl.finite) failures.emplace_back("the base's state is not finite");
    // Only fleet messages may be applied when no unknown robot is allowed: exactly these.
    if (o.unknown_robots == 0 &&
        (fl.odometry_applied != static_cast<long long>(fleet.odometry()) || fl.features_applied != static_cast<long long>(fleet.features()) ||
         fl.odometry_dup != 0 || fl.odometry_gaps != 0 || fl.features_dup != 0 || fl.robots_restarted != 0)) {
      std::snprintf(b, sizeof b,
                    "the base applied odometry %lld (%lld dup, %lld gaps), features %lld (%lld dup), %lld restarts; the fleet sent "
                    "%llu and %llu",
                    fl.odometry_applied, fl.odometry_dup, fl.odometry_gaps, fl.features_applied, fl.features_dup, fl.robots_restarted,
                    static_cast<unsigned long long>(fleet.odometry()), static_cast<unsigned long long>(fleet.features()));
      failures.emplace_back(b);
    }
    if (traffic.total() >= 2000) {
      for (const std::string& reason : expected_refusals(o, traffic)) {
        if (!fl.rejected.contains(reason)) failures.push_back("the base counted no '" + reason + "' refusal: did the fuzz reach it?");
      }
    }
  }
  const std::string fleet_line = fuzz::last_line_with(log, "status(es) of unlisted robots refused");
  long long fleet_refused = -1;
  if (const auto at = fleet_line.find(" alive, "); at != std::string::npos) fleet_refused = std::atoll(fleet_line.c_str() + at + 8);
  if (traffic.total() >= 2000 && traffic.fuzzes(fuzz::Topic::kStatus) && fleet_refused <= 0) {
    failures.emplace_back("the fleet table refused no status of an unlisted robot: did the fuzz reach it?");
  }
  // Samples written in another robot's partition are dropped by the base's readers, counted.
  long long foreign_dropped = -1;
  if (const auto at = fleet_line.find(" refused, "); at != std::string::npos) foreign_dropped = std::atoll(fleet_line.c_str() + at + 10);
  if (traffic.misplaced() > 0 && foreign_dropped <= 0) {
    std::snprintf(b, sizeof b, "the base dropped no sample of another robot's id (%llu written in the wrong partition)",
                  static_cast<unsigned long long>(traffic.misplaced()));
    failures.emplace_back(b);
  }
  // Visit requests for robots the fusion does not hold are refused and counted.
  const std::string explore_line = fuzz::last_line_with(log, "explore: ");
  long long visits_refused = -1;
  if (const auto v = explore_line.find(" visits "); v != std::string::npos) {
    if (const auto at = explore_line.find("(refused ", v); at != std::string::npos) {
      visits_refused = std::atoll(explore_line.c_str() + at + 9);
    }
  }
  if (traffic.total() >= 2000 && traffic.fuzzes(fuzz::Topic::kVisit) && visits_refused <= 0) {
    failures.emplace_back("the executive refused no visit request: did the fuzz reach it?");
  }
  // Memory: growth over the second half of what actually ran.
  double rss_half = 0, rss_end = 0, rss_peak = 0;
  for (const auto& [t, mib] : rss) {
    if (t <= ran_s / 2) rss_half = mib;
    rss_end = mib;
    rss_peak = std::max(rss_peak, mib);
  }
  const double growth = rss_end - rss_half;
  if (o.max_rss_growth_mib > 0 && growth > o.max_rss_growth_mib) {
    std::snprintf(b, sizeof b, "the base's memory grew %.1f MiB in the second half of the run (bound %.1f MiB)", growth,
                  o.max_rss_growth_mib);
    failures.emplace_back(b);
  }
  // The real robots' estimates against the reference.
  double max_dp = 0, max_dth = 0;
  nlohmann::json estimates = nlohmann::json::array();
  for (int r = 1; r <= o.robots; ++r) {
    const auto id = static_cast<std::uint16_t>(r);
    msg::PoseCorrection ref{};
    const bool have_ref = reference.correction(id, 0, &ref);
    const auto it = last_corr.find(id);
    if (!have_ref || it == last_corr.end()) {
      failures.push_back("no estimate of robot " + std::to_string(r) + (have_ref ? " from the base" : " in the reference"));
      continue;
    }
    const cairn_Pose2& g = it->second.global_pose;
    const double dp = std::hypot(g.x - ref.global_pose.x, g.y - ref.global_pose.y);
    const double dth = std::abs(normalize_angle(g.theta - ref.global_pose.theta));
    max_dp = std::max(max_dp, std::isfinite(dp) ? dp : 1e9);
    max_dth = std::max(max_dth, std::isfinite(dth) ? dth : 1e9);
    estimates.push_back({{"robot", r},
                         {"base", {g.x, g.y, g.theta}},
                         {"reference", {ref.global_pose.x, ref.global_pose.y, ref.global_pose.theta}},
                         {"position_error_m", dp},
                         {"heading_error_rad", dth}});
  }
  if (o.check_estimates && (max_dp > o.tolerance_m || max_dth > o.tolerance_rad)) {
    std::snprintf(b, sizeof b,
                  "a real robot's estimate moved %.4f m / %.4f rad from the run without the fuzzer (tolerance %.3f m / %.3f rad)", max_dp,
                  max_dth, o.tolerance_m, o.tolerance_rad);
    failures.emplace_back(b);
  }

  nlohmann::json report, sent;
  for (std::size_t t = 0; t < fuzz::kTopics; ++t) {
    nlohmann::json by = nlohmann::json::object();
    std::uint64_t total = 0;
    for (std::size_t m = 0; m < fuzz::kMutations; ++m) {
      const std::uint64_t n = traffic.sent(static_cast<fuzz::Topic>(t), static_cast<fuzz::Mutation>(m));
      if (n == 0) continue;
      by[fuzz::mutation_name(static_cast<fuzz::Mutation>(m))] = n;
      total += n;
    }
    sent[fuzz::topic_name(static_cast<fuzz::Topic>(t))] = {{"total", total}, {"by_mutation", by}};
  }
  report["seconds"] = ran_s;
  report["seed"] = o.seed;
  report["rate"] = o.rate;
  report["sweep_ids"] = o.sweep_ids;
  report["unknown_robots"] = o.unknown_robots;
  report["estimates_checked"] = o.check_estimates;
  report["memory_checked"] = o.max_rss_growth_mib > 0;
  report["sent"] = sent;
  report["sent_total"] = traffic.total();
  report["refused_by_writer"] = traffic.refused_by_writer();
  report["misplaced"] = traffic.misplaced();
  report["base_dropped_misplaced"] = foreign_dropped;
  report["fleet"] = {{"robots", o.robots}, {"odometry", fleet.odometry()}, {"features", fleet.features()}};
  report["base"] = {{"exit", exit.describe()},
                    {"state_finite", fl.finite},
                    {"applied", {{"odometry", fl.odometry_applied}, {"features", fl.features_applied}}},
                    {"rejected", fl.rejected},
                    {"fleet_statuses_refused", fleet_refused},
                    {"visit_requests_refused", visits_refused},
                    {"final", final_line},
                    {"rss_mib", {{"half", rss_half}, {"end", rss_end}, {"peak", rss_peak}, {"growth_second_half", growth}}}};
  report["estimates"] = estimates;
  report["max_position_error_m"] = max_dp;
  report["max_heading_error_rad"] = max_dth;
  report["failures"] = failures;
  report["pass"] = failures.empty();
  report["work_dir"] = dir.string();
  if (o.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    std::printf("cairn-fuzz-base: %llu fuzz samples in %.0f s (%llu refused by the writer) beside %d robots (%llu odometry, %llu features)\n",
                static_cast<unsigned long long>(traffic.total()), ran_s, static_cast<unsigned long long>(traffic.refused_by_writer()),
                o.robots, static_cast<unsigned long long>(fleet.odometry()), static_cast<unsigned long long>(fleet.features()));
    std::printf("  base: %s, state %s, RSS %.1f MiB at half time, %.1f MiB at the end (peak %.1f)\n", exit.describe().c_str(),
                fl.finite ? "finite" : "NOT FINITE", rss_half, rss_end, rss_peak);
    std::printf("  base %s\n", final_line.c_str());
    std::printf("  real robots: max deviation from the run without the fuzzer %.4f m, %.4f rad\n", max_dp, max_dth);
    for (const auto& f : failures) std::printf("  FAIL: %s\n", f.c_str());
    std::printf("cairn-fuzz-base: %s (base log: %s)\n", failures.empty() ? "PASS" : "FAIL", (dir / "base.log").string().c_str());
  }
  if (failures.empty() && o.work_dir.empty()) fs::remove_all(dir);
  return failures.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-fuzz-base: starts cairn-base on the loopback DDS profile beside a simulated fleet, floods every\n"
               "topic the base reads (odometry, features, scans, status, bids, visit requests) with random and mutated samples, and\n"
               "checks that the base stays up, its state finite, its memory bounded, its refusals counted, and the\n"
               "real robots' estimates those of the same fleet without the fuzzer. Exit status 0 = all held\n"
               "(docs/fuzz-base.md)."};
  Options o;
  app.add_option("--seconds", o.seconds, "how long to fuzz")->check(CLI::Range(1.0, 86400.0));
  app.add_option("--rate", o.rate, "fuzz samples per second over all topics (0 = the fleet alone)")->check(CLI::Range(0.0, 100000.0));
  app.add_option("--fleet-rate", o.fleet_rate, "fleet odometry steps per second (a step is 0.1 s of driving)")->check(CLI::Range(1.0, 1000.0));
  app.add_option("--robots", o.robots, "robots in the simulated fleet (ids 1..N)")->check(CLI::Range(1, 10));
  app.add_option("--seed", o.seed, "seed of the fuzz samples (a run is reproducible up to DDS timing)");
  app.add_option("--domain", o.domain, "DDS domain (default: 150 + pid % 80)")->check(CLI::Range(0, 230));
  app.add_option("--base", o.base_bin, "the cairn-base to test (default: next to this program, else in the build tree, else PATH)");
  app.add_option("--work-dir", o.work_dir, "keep the base's config, log, state and map here (default: a temporary directory, removed on success)");
  app.add_option("--tolerance-m", o.tolerance_m, "allowed deviation of a real robot's position from the run without the fuzzer");
  app.add_option("--tolerance-rad", o.tolerance_rad, "allowed deviation of its heading");
  app.add_option("--max-rss-growth-mib", o.max_rss_growth_mib,
                 "allowed growth of the base's resident memory over the second half of the run (0: not checked, "
                 "e.g. under ASan, whose quarantine keeps freed memory resident)");
  app.add_option("--topics", o.topics, "fuzz only these topics (default: all)")
      ->check(CLI::IsMember({"odometry", "features", "scan", "status", "bid", "visit"}))
      ->delimiter(',');
  app.add_option("--unknown-robots", o.unknown_robots,
                 "let up to N robots outside the fleet join ([unknown_robot] allow): fake robots then drive, relocate "
                 "and map (default 0: the configured fleet only)")
      ->check(CLI::Range(0, 1000));
  app.add_flag("--no-estimate-check", [&](std::int64_t) { o.check_estimates = false; },
               "report the real robots' deviation but do not fail on it (fake robots admitted by --unknown-robots "
               "feed the shared map: docs/fuzz-base.md)");
  app.add_flag("--sweep-ids", o.sweep_ids,
               "ids outside the fleet walk through all 65536 instead of at random: the readers' most instances");
  app.add_flag("--json", o.json, "print the report as JSON");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-fuzz-base", [&] { return run(o); });
}
