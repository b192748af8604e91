// cairn-eval explore: the exploration seed's experiments (issue 15 item 4) on cairn-sim's
// fleet: runs x robot counts [x modes] of one world, times to 50 / 90 / 95 / 100 % coverage,
// completed and failed runs, the coverage curves and the seed's figures as PNG.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "basestation/mapper/export.hpp"
#include "common/log.hpp"
#include "tools/eval/commands.hpp"
#include "tools/eval/explore_stats.hpp"
#include "tools/eval/plot.hpp"
#include "tools/sim/fleet_sim.hpp"

namespace cairn::eval {
namespace {

constexpr double kCoveragePeriodS = 5;  // the coverage record (and so the times' resolution)

struct RunSpec {
  std::string mode;
  int robots = 0, run = 0;
  std::uint64_t seed = 0;
  std::string world_path;
  bool shared_world = false;
  double cells_per_metre = -1;  // < 0: the allocator's default
};

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The world's text with the seed of its `random FRACTION SEED CELL` line(s) increased by
// `offset`: another map of the same kind. Throws when the world has no random line.
std::string with_random_seed_offset(const std::string& text, const std::string& path, std::uint64_t offset) {
  std::istringstream in(text);
  std::string line, out;
  bool found = false;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string kw, fraction, seed, cell;
    if (words >> kw && kw == "random" && words >> fraction >> seed >> cell) {
      const std::uint64_t s = std::stoull(seed) + offset;
      line = "random " + fraction + " " + std::to_string(s) + " " + cell + "  # " + path + ", seed + " +
             std::to_string(offset);
      found = true;
    }
    out += line + "\n";
  }
  if (!found) throw std::invalid_argument("--random-maps: " + path + " has no 'random FRACTION SEED CELL' line");
  return out;
}

std::string run_name(const RunSpec& s) {
  return s.mode + "-r" + std::to_string(s.robots) + "-run" + std::to_string(s.run);
}

ExploreRun run_one(const RunSpec& spec, double duration, const std::string& out_dir) {
  sim::FleetSimConfig cfg;
  cfg.world_path = spec.world_path;
  cfg.robots = spec.robots;
  cfg.threads = 1;  // runs go in parallel instead
  cfg.duration_s = duration;
  cfg.seed = spec.seed;
  cfg.explore = true;
  cfg.shared_world = spec.shared_world;
  cfg.exploration.allocator.coordinated = spec.mode == "coordinated";
  if (spec.cells_per_metre >= 0) {  // both sides: the robots rank (and cut) their bids with the base's rate
    cfg.exploration.allocator.cells_per_metre = spec.cells_per_metre;
    cfg.exploration.bidder.gain_per_metre = spec.cells_per_metre;
  }
  cfg.coverage_period = static_cast<Nanos>(kCoveragePeriodS * 1e9);
  sim::set_tool_speeds(&cfg);
  const auto t0 = std::chrono::steady_clock::now();
  sim::FleetSim fleet(cfg);
  fleet.run();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const sim::FleetSummary s = fleet.summary(wall);

  ExploreRun r;
  r.mode = spec.mode;
  r.robots = spec.robots;
  r.run = spec.run;
  r.seed = spec.seed;
  r.world = spec.world_path;
  for (std::size_t k = 0; k < 4; ++k) r.time_to[k] = s.time_to_coverage[k];
  r.explored = s.explore && s.explore->explored;
  r.explored_at_s = r.explored ? s.explore->explored_at_s : 0;
  r.final_coverage = s.map.coverage;
  r.final_drivable = s.map.drivable_coverage;
  r.agreement = s.map.agreement;
  r.wall_offset_max_m = s.map.wall_offset_max_m;
  r.closest_approach_m = s.closest_approach_m;
  for (const auto& rb : s.robots) {
    r.distance_m += rb.distance_m;
    r.bump_steps += rb.bumps;
  }
  for (const auto& c : s.coverage) {
    r.curve_t.push_back(c.t_s);
    r.curve_coverage.push_back(c.coverage);
  }
  r.wall_s = wall;

  const std::string dir = out_dir + "/runs/" + run_name(spec);
  std::filesystem::create_directories(dir);
  std::ofstream cov(dir + "/coverage.csv");
  cov << "t_s,coverage,agreement,drivable_coverage\n";
  char line[96];
  for (const auto& c : s.coverage) {
    std::snprintf(line, sizeof line, "%.3f,%.6f,%.6f,%.6f\n", c.t_s, c.coverage, c.agreement, c.drivable);
    cov << line;
  }
  if (!cov) throw std::runtime_error("cannot write " + dir + "/coverage.csv");
  mapper::write_png(fleet.map().classified(), fleet.estimated_trajectories(), fleet.landmarks(), dir + "/map.png");
  return r;
}

nlohmann::json opt(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); }

nlohmann::json times_json(const ExploreRun& r) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t k = 0; k < 4; ++k) j[level_name(k)] = opt(r.time_to[k]);
  return j;
}

nlohmann::json group_json(const ExploreGroup& g) {
  nlohmann::json levels = nlohmann::json::object();
  for (std::size_t k = 0; k < 4; ++k) {
    const LevelStats& l = g.level[k];
    levels[level_name(k)] = {{"reached", l.reached}, {"mean", opt(l.mean)}, {"sd", opt(l.sd)}, {"min", opt(l.min)},
                             {"max", opt(l.max)}};
  }
  return {{"mode", g.mode},
          {"robots", g.robots},
          {"runs", g.runs},
          {"completed", g.completed},
          {"failures", g.failures},
          {"time_to_coverage_s", levels},
          {"coverage_mean", g.coverage_mean},
          {"drivable_coverage_mean", g.drivable_mean},
          {"agreement_mean", g.agreement_mean},
          {"explored_at_mean_s", g.completed ? nlohmann::json(g.explored_at_mean) : nlohmann::json()},
          {"closest_approach_min_m", opt(g.closest_approach_min_m)},
          {"bump_steps", g.bump_steps}};
}

const ExploreGroup* find_group(const std::vector<ExploreGroup>& gs, const std::string& mode, int robots) {
  for (const auto& g : gs) {
    if (g.mode == mode && g.robots == robots) return &g;
  }
  return nullptr;
}

// "82 ± 5 (10)": mean ± sd (runs that reached it), or "—".
std::string cell(const LevelStats& l, std::size_t runs) {
  if (!l.mean) return "—";
  char buf[64];
  if (l.sd) {
    std::snprintf(buf, sizeof buf, "%.0f ± %.0f", *l.mean, *l.sd);
  } else {
    std::snprintf(buf, sizeof buf, "%.0f", *l.mean);
  }
  std::string s = buf;
  if (l.reached != runs) s += " (" + std::to_string(l.reached) + " of " + std::to_string(runs) + ")";
  return s;
}

std::string markdown_table(const std::vector<ExploreGroup>& gs) {
  std::string t =
      "| mode | robots | runs | explored | failures | 50 % (s) | 90 % (s) | 95 % (s) | 100 % (s) | final coverage | "
      "drivable coverage | agreement | closest approach (m) | bump steps |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[128];
  for (const auto& g : gs) {
    t += "| " + g.mode + " | " + std::to_string(g.robots) + " | " + std::to_string(g.runs) + " | " +
         std::to_string(g.completed) + " | " + std::to_string(g.failures) + " | ";
    for (std::size_t k = 0; k < 4; ++k) t += cell(g.level[k], g.runs) + " | ";
    std::snprintf(buf, sizeof buf, "%.3f | %.3f | %.3f | ", g.coverage_mean, g.drivable_mean, g.agreement_mean);
    t += buf;
    if (g.closest_approach_min_m) {
      std::snprintf(buf, sizeof buf, "%.2f | ", *g.closest_approach_min_m);
      t += buf;
    } else {
      t += "— | ";
    }
    t += std::to_string(g.bump_steps) + " |\n";
  }
  return t;
}

void plot(const std::vector<ExploreGroup>& gs, const std::string& world_name, const std::string& out, int runs) {
  Figure cov;
  cov.title = world_name + ": mean coverage over " + std::to_string(runs) + " runs";
  cov.xlabel = "simulated time (s)";
  cov.ylabel = "coverage of the reachable free space";
  cov.extra.push_back("set yrange [0:1.02]");
  Figure times;
  times.title = world_name + ": time to coverage (mean ± sd over the runs that reached it)";
  times.xlabel = "coverage level (%)";
  times.ylabel = "simulated time (s)";
  times.extra.push_back("set xtics ('50' 1, '90' 2, '95' 3, '100' 4)");
  times.extra.push_back("set xrange [0.5:4.5]");
  times.extra.push_back("set yrange [0:*]");
  for (std::size_t i = 0; i < gs.size(); ++i) {
    const ExploreGroup& g = gs[i];
    const std::string title = std::to_string(g.robots) + (g.robots == 1 ? " robot" : " robots") +
                              (g.mode == "coordinated" ? "" : ", uncoordinated");
    Series c{title, g.curve_t, g.curve_mean, g.mode == "coordinated" ? "lines lw 2" : "lines lw 2 dt 2"};
    cov.series.push_back(std::move(c));
    Series t{title, {}, {}, "yerrorbars pt 7 ps 1.2"};
    const double dx = (static_cast<double>(i) - static_cast<double>(gs.size() - 1) / 2) * 0.12;
    for (std::size_t k = 0; k < 4; ++k) {
      if (!g.level[k].mean) continue;
      t.x.push_back(static_cast<double>(k + 1) + dx);
      t.y.push_back(*g.level[k].mean);
      t.err.push_back(g.level[k].sd.value_or(0));
    }
    if (!t.x.empty()) times.series.push_back(std::move(t));
  }
  render_png(cov, out, "coverage");
  if (!times.series.empty()) render_png(times, out, "time_to_coverage");
}

}  // namespace

int explore(const ExploreCmdOptions& o) {
  if (o.robots.empty()) throw std::invalid_argument("--robots: give at least one robot count");
  const std::string out = o.out_dir.empty() ? "explore-" + std::filesystem::path(o.world).stem().string() : o.out_dir;
  std::filesystem::create_directories(out);
  const std::string world_name = hil::World::load(o.world).name();  // a bad file fails before any run
  // Dozens of fleets log in one process on simulated time: their warnings (each robot's
  // "laser silent" before its first scan) would drown the progress lines. The runs'
  // figures carry what matters; --verbose keeps the logs.
  if (!o.verbose) logger().set_min_level(LogLevel::kError);

  std::vector<std::string> worlds;  // per run index
  for (int k = 0; k < o.runs; ++k) {
    if (!o.random_maps) {
      worlds.push_back(o.world);
      continue;
    }
    const std::string path = out + "/worlds/map" + std::to_string(k) + ".world";
    std::filesystem::create_directories(out + "/worlds");
    std::ofstream(path) << with_random_seed_offset(read_text(o.world), o.world, static_cast<std::uint64_t>(k));
    hil::World::load(path);  // refuse a bad map before running
    worlds.push_back(path);
  }

  std::vector<RunSpec> specs;
  for (const std::string mode : {"coordinated", "uncoordinated"}) {
    if (o.mode != "both" && o.mode != mode) continue;
    for (int n : o.robots) {
      if (o.mode == "both" && mode == std::string("uncoordinated") && n == 1) continue;  // one robot: the same run
      for (int k = 0; k < o.runs; ++k) {
        specs.push_back(
            {mode, n, k, o.seed + static_cast<std::uint64_t>(k), worlds[static_cast<std::size_t>(k)], o.shared_world,
             o.cells_per_metre});
      }
    }
  }

  const unsigned jobs = o.jobs > 0 ? static_cast<unsigned>(o.jobs) : std::max(1u, std::thread::hardware_concurrency());
  std::fprintf(stderr, "cairn-eval explore: %s, %zu runs of up to %.0f simulated s, %u at once; output in %s\n",
               world_name.c_str(), specs.size(), o.duration, jobs, out.c_str());
  std::vector<ExploreRun> results(specs.size());
  std::atomic<std::size_t> next{0};
  std::size_t done = 0;
  std::mutex mu;
  std::exception_ptr error;
  const auto t0 = std::chrono::steady_clock::now();
  auto worker = [&] {
    while (true) {
      const std::size_t i = next.fetch_add(1);
      if (i >= specs.size()) return;
      try {
        results[i] = run_one(specs[i], o.duration, out);
      } catch (...) {
        std::lock_guard lock(mu);
        if (!error) error = std::current_exception();
        next.store(specs.size());
        return;
      }
      std::lock_guard lock(mu);
      const ExploreRun& r = results[i];
      ++done;
      std::fprintf(stderr, "  [%zu/%zu] %s, %d robot(s), run %d (seed %llu): ", done, specs.size(), r.mode.c_str(),
                   r.robots, r.run, static_cast<unsigned long long>(r.seed));
      if (r.time_to[2]) {
        std::fprintf(stderr, "95 %% at %.0f s, ", *r.time_to[2]);
      } else {
        std::fprintf(stderr, "95 %% not reached, ");
      }
      if (r.explored) {
        std::fprintf(stderr, "explored at %.0f s", r.explored_at_s);
      } else {
        std::fprintf(stderr, "NOT explored by %.0f s", o.duration);
      }
      std::fprintf(stderr, ", coverage %.3f (drivable %.3f), agreement %.3f%s (%.0f s wall)\n", r.final_coverage,
                   r.final_drivable, r.agreement,
                   is_failure(r) ? " FAILED" : "", r.wall_s);
    }
  };
  std::vector<std::thread> threads;
  for (unsigned j = 0; j < std::min<std::size_t>(jobs, specs.size()); ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const std::vector<ExploreGroup> groups = aggregate(results, kCoveragePeriodS, o.duration);
  nlohmann::json gj = nlohmann::json::array();
  for (const auto& g : groups) gj.push_back(group_json(g));
  nlohmann::json speed = nlohmann::json::object(), coord = nlohmann::json::object();
  for (int a : o.robots) {
    for (int b : o.robots) {
      const ExploreGroup* ga = find_group(groups, "coordinated", a);
      const ExploreGroup* gb = find_group(groups, "coordinated", b);
      if (a < b && ga && gb) speed[std::to_string(b) + "_vs_" + std::to_string(a)] = opt(speedup(*ga, *gb, 2));
    }
    const ExploreGroup* c = find_group(groups, "coordinated", a);
    const ExploreGroup* u = find_group(groups, "uncoordinated", a);
    if (c && u) coord[std::to_string(a)] = opt(speedup(*u, *c, 2));
  }
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& r : results) {
    runs.push_back({{"mode", r.mode},
                    {"robots", r.robots},
                    {"run", r.run},
                    {"seed", r.seed},
                    {"world", r.world},
                    {"time_to_coverage_s", times_json(r)},
                    {"explored", r.explored},
                    {"explored_at_s", r.explored ? nlohmann::json(r.explored_at_s) : nlohmann::json()},
                    {"final_coverage", r.final_coverage},
                    {"final_drivable_coverage", r.final_drivable},
                    {"agreement", r.agreement},
                    {"failed", is_failure(r)},
                    {"wall_offset_max_m", r.wall_offset_max_m},
                    {"distance_m", r.distance_m},
                    {"bump_steps", r.bump_steps},
                    {"closest_approach_m", opt(r.closest_approach_m)},
                    {"wall_seconds", r.wall_s}});
  }
  const nlohmann::json summary = {
      {"world", o.world},
      {"world_name", world_name},
      {"random_maps", o.random_maps},
      {"shared_world", o.shared_world},
      {"duration_s", o.duration},
      {"cells_per_metre", o.cells_per_metre >= 0 ? nlohmann::json(o.cells_per_metre) : nlohmann::json(nullptr)},
      {"seed", o.seed},
      {"coverage_period_s", kCoveragePeriodS},
      {"failure_if_agreement_below", kFailureAgreement},
      {"groups", gj},
      // mean time to 95 % of the fewer robots / of the more; null unless every run of both reached 95 %
      {"speedup_to_95", speed},
      // mean time to 95 % uncoordinated / coordinated, per robot count
      {"coordination_gain_to_95", coord},
      {"runs", runs},
      {"wall_seconds", wall}};
  std::ofstream(out + "/summary.json") << summary.dump(2) << "\n";
  const std::string table = markdown_table(groups);
  std::ofstream(out + "/table.md") << table;
  plot(groups, world_name, out, o.runs);

  if (o.json) {
    std::printf("%s\n", summary.dump(2).c_str());
  } else {
    std::printf("%s: %zu runs in %.0f s wall (times in simulated s, mean ± sd)\n%s", world_name.c_str(), results.size(),
                wall, table.c_str());
    for (const auto& [k, v] : speed.items()) {
      std::printf("time to 95 %%, %s robots: %s\n", k.c_str(), v.is_null() ? "n/a (not every run reached 95 %)"
                                                                           : (std::to_string(v.get<double>()) + "x sooner").c_str());
    }
    for (const auto& [k, v] : coord.items()) {
      std::printf("time to 95 %%, %s robots, coordinated vs uncoordinated: %s\n", k.c_str(),
                  v.is_null() ? "n/a" : (std::to_string(v.get<double>()) + "x sooner").c_str());
    }
    std::printf("written: %s/summary.json, table.md, coverage.png, time_to_coverage.png, runs/*/{coverage.csv,map.png}\n",
                out.c_str());
  }
  return 0;
}

}  // namespace cairn::eval
