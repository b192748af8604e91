// cairn-sim: a deterministic fleet simulation on simulated time (docs/sim.md). N robots
// run the production robot pipeline in one shared world, fed by the LMS2xx emulator's
// measurement model and encoders with slip; the production base fusion runs beside them.
//   cairn-sim --world hil/worlds/office.world --robots 3 --duration 300 --seed 7 --out DIR --json
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/program.hpp"
#include "firmware/robot_config.hpp"
#include "basestation/mapper/export.hpp"
#include "tools/sim/fleet_sim.hpp"

using namespace cairn;

namespace {

// {"50": t or null, "90": ..., "95": ..., "100": ...}: the first recorded time at each coverage level.
nlohmann::json time_to_coverage(const sim::FleetSummary& s) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t k = 0; k < 4; ++k) {
    const std::string key = std::to_string(static_cast<int>(sim::kCoverageLevels[k] * 100 + 0.5));
    j[key] = s.time_to_coverage[k] ? nlohmann::json(*s.time_to_coverage[k]) : nlohmann::json();
  }
  return j;
}

nlohmann::json to_json(const sim::FleetSummary& s, bool with_wall_time) {
  nlohmann::json robots = nlohmann::json::array();
  for (const auto& r : s.robots) {
    robots.push_back({{"id", r.id},
                      {"distance_m", r.distance_m},
                      {"local_rmse_m", r.local_rmse_m},
                      {"global_rmse_m", r.global_rmse_m},
                      {"local_final_error_m", r.local_final_err_m},
                      {"global_final_error_m", r.global_final_err_m},
                      {"global_nees_pose", r.global_nees_pose},
                      {"global_nees_position", r.global_nees_position},
                      {"scans", r.scans},
                      {"matched", r.matched},
                      {"bumps", r.bumps}});
  }
  nlohmann::json j = {{"robots", robots},
                      {"landmarks", s.landmarks},
                      {"poles", s.poles},
                      {"landmark_rmse_m", s.landmark_rmse_m},
                      {"landmarks_far_from_any_pole", s.landmarks_far},
                      {"messages", s.messages},
                      {"messages_lost", s.messages_lost},
                      {"robot_sightings",
                       {{"seen", s.robot_sightings},
                        {"unidentified", s.robot_sightings_unidentified},
                        {"unidentified_paired", s.robot_sightings_paired},
                        {"fused", s.robot_observations_used},
                        {"nis_mean", s.sighting_nis_mean ? nlohmann::json(*s.sighting_nis_mean) : nlohmann::json()}}},
                      {"closest_approach_m", s.closest_approach_m ? nlohmann::json(*s.closest_approach_m) : nlohmann::json()},
                      {"landmark_nis_mean", s.landmark_nis_mean ? nlohmann::json(*s.landmark_nis_mean) : nlohmann::json()},
                      {"map",
                       {{"scans_inserted", s.map_scans},
                        {"scans_unplaced", s.map_scans_unplaced},
                        {"coverage", s.map.coverage},
                        {"drivable_coverage", s.map.drivable_coverage},
                        {"robot_radius_m", s.map.robot_radius_m},
                        {"agreement", s.map.agreement},
                        {"false_obstacles", s.map.false_obstacles},
                        {"false_free", s.map.false_free},
                        {"wall_offset_mean_cells", s.map.wall_offset_mean_cells()},
                        {"wall_offset_p95_cells", s.map.resolution > 0 ? s.map.wall_offset_p95_m / s.map.resolution : 0.0},
                        {"wall_offset_max_cells", s.map.wall_offset_max_cells()}}},
                      {"sim_seconds", s.sim_seconds},
                      {"steps", s.steps}};
  if (!s.coverage.empty()) j["time_to_coverage_s"] = time_to_coverage(s);  // recorded: --coverage-period / --explore
  if (s.explore) {
    const auto& a = s.explore->allocator;
    const auto& d = s.explore->driver;
    nlohmann::json unreachable = nlohmann::json::array();
    for (const explore::UnreachableArea& u : s.explore->unreachable) {
      unreachable.push_back({{"kind", explore::to_string(u.kind)},
                             {"x", u.x},
                             {"y", u.y},
                             {"min_x", u.min_x},
                             {"min_y", u.min_y},
                             {"max_x", u.max_x},
                             {"max_y", u.max_y},
                             {"cells", u.cells},
                             {"robots", u.robots}});
    }
    j["explore"] = {{"explored", s.explore->explored},
                    {"unreachable", unreachable},
                    {"unreachable_dropped", s.explore->unreachable_dropped},
                    {"explored_at_s", s.explore->explored ? nlohmann::json(s.explore->explored_at_s) : nlohmann::json()},
                    {"allocator",
                     {{"bids_received", a.bids_received},
                      {"bids_rejected", a.bids_rejected},
                      {"rounds", a.rounds},
                      {"explore_assigned", a.explore_assigned},
                      {"tasks_kept", a.tasks_kept},
                      {"switches", a.switches},
                      {"idles", a.idles},
                      {"arrivals", a.arrivals},
                      {"timeouts", a.timeouts},
                      {"stuck_reports", a.stuck_reports},
                      {"bars_set", a.bars_set},
                      {"attempts", a.attempts},
                      {"frontiers_given_up", a.frontiers_given_up},
                      {"given_up_released", a.given_up_released},
                      {"explored_reports", a.explored_reports},
                      {"assignments_emitted", a.assignments_emitted},
                      {"visits_requested", a.visits_requested},
                      {"visits_rejected", a.visits_rejected},
                      {"visits_arrived", a.visits_arrived},
                      {"visits_failed", a.visits_failed}}},
                    {"driver",
                     {{"bids", d.bids},
                      {"bids_no_frontier", d.bids_no_frontier},
                      {"bids_failed", d.bids_failed},
                      {"plans", d.plans},
                      {"plan_failures", d.plan_failures},
                      {"replans_after_bump", d.replans_after_bump},
                      {"blocks_marked", d.blocks_marked},
                      {"yields", d.yields},
                      {"periods_on_distinct_frontiers", d.periods_on_distinct_frontiers},
                      {"visits_taken", d.visits_taken},
                      {"visits_refused", d.visits_refused}}}};
  }
  if (with_wall_time) {
    j["wall_seconds"] = s.wall_seconds;
    j["speed_factor"] = s.speed_factor;
    j["steps_per_second"] = s.steps_per_second;
  }
  return j;
}

void write_outputs(const std::string& dir, const sim::FleetSim& fleet, const sim::FleetSummary& s) {
  std::filesystem::create_directories(dir);
  std::ofstream truth(dir + "/trajectories.csv");
  truth << "t_s,robot,truth_x,truth_y,truth_theta,local_x,local_y,local_theta,global_x,global_y,global_theta,global_var_x,global_var_y,global_var_theta\n";
  char line[320];
  for (const auto& x : fleet.samples()) {
    std::snprintf(line, sizeof line, "%.3f,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,", nanos_to_seconds(x.t), x.robot, x.truth.x,
                  x.truth.y, x.truth.theta, x.local.x, x.local.y, x.local.theta);
    truth << line;
    if (x.has_global) {
      std::snprintf(line, sizeof line, "%.6f,%.6f,%.6f,%.9g,%.9g,%.9g\n", x.global.x, x.global.y, x.global.theta,
                    x.global_cov(0, 0), x.global_cov(1, 1), x.global_cov(2, 2));
      truth << line;
    } else {
      truth << ",,,,,\n";
    }
  }
  std::ofstream lm(dir + "/landmarks.csv");
  lm << "id,x,y,cov_xx,cov_xy,cov_yy\n";
  for (const auto& l : fleet.landmarks()) {
    std::snprintf(line, sizeof line, "%u,%.6f,%.6f,%.9g,%.9g,%.9g\n", l.id, l.x, l.y, l.cov[0], l.cov[1], l.cov[3]);
    lm << line;
  }
  // The central map: as ROS map_server loads it, as a picture with the base's trajectory
  // estimates and landmarks (3-sigma ellipses) and, when exploring, the unreachable
  // frontiers outlined (as cairn-base's export, with frontiers.json), and the landmark map as JSON.
  const mapper::ClassGrid grid = fleet.map().classified();
  mapper::write_map_server(grid, dir + "/map");
  mapper::PngOptions png;
  if (s.explore) {
    for (const explore::UnreachableArea& a : s.explore->unreachable)
      png.boxes.push_back({a.min_x, a.min_y, a.max_x, a.max_y,
                           a.kind == msg::UnreachableKind::kTooNarrow ? mapper::kTooNarrowRgb : mapper::kDisconnectedRgb});
    std::ofstream fr(dir + "/frontiers.json");
    fr << explore::unreachable_json(s.explore->unreachable, s.explore->unreachable_dropped);
    if (!fr) throw std::runtime_error("cannot write " + dir + "/frontiers.json");
  }
  mapper::write_png(grid, fleet.estimated_trajectories(), fleet.landmarks(), dir + "/map.png", png);
  mapper::write_landmarks_json(fleet.landmarks(), dir + "/landmarks.json");
  if (!s.coverage.empty()) {
    std::ofstream cov(dir + "/coverage.csv");
    cov << "t_s,coverage,agreement,drivable_coverage\n";
    for (const auto& c : s.coverage) {
      std::snprintf(line, sizeof line, "%.3f,%.6f,%.6f,%.6f\n", c.t_s, c.coverage, c.agreement, c.drivable);
      cov << line;
    }
    if (!cov) throw std::runtime_error("cannot write " + dir + "/coverage.csv");
  }
  std::ofstream(dir + "/summary.json") << to_json(s, false).dump(2) << "\n";  // no wall time: repeatable
  if (!truth || !lm) throw std::runtime_error("cannot write the outputs in " + dir);
}

int run(const sim::FleetSimConfig& cfg, const std::string& out, bool json) {
  const auto t0 = std::chrono::steady_clock::now();
  sim::FleetSim fleet(cfg);
  std::fprintf(stderr, "cairn-sim: %d robot(s) in %s for %.0f s (seed %llu)\n", cfg.robots, fleet.world().name().c_str(),
               cfg.duration_s, static_cast<unsigned long long>(cfg.seed));
  fleet.run([&](double t) {
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "\r  simulated %5.0f / %.0f s (%.1fx real time)", t, cfg.duration_s, wall > 0 ? t / wall : 0.0);
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "\n");
  const sim::FleetSummary s = fleet.summary(wall);
  if (!out.empty()) write_outputs(out, fleet, s);
  if (json) {
    std::printf("%s\n", to_json(s, true).dump(2).c_str());
  } else {
    std::printf("%-6s %10s %14s %15s %9s %8s %8s %6s\n", "robot", "distance m", "local rmse m", "global rmse m",
                "nees (3)", "scans", "matched", "bumps");
    for (const auto& r : s.robots) {
      std::printf("%-6d %10.1f %14.3f %15.3f %9.1f %8llu %8llu %6llu\n", r.id, r.distance_m, r.local_rmse_m,
                  r.global_rmse_m, r.global_nees_pose,
                  static_cast<unsigned long long>(r.scans), static_cast<unsigned long long>(r.matched),
                  static_cast<unsigned long long>(r.bumps));
    }
    std::printf("landmarks %zu (poles %zu), rmse to nearest pole %.3f m, %zu farther than 0.5 m\n", s.landmarks, s.poles,
                s.landmark_rmse_m, s.landmarks_far);
    std::printf("robots seen by robots: %llu sightings, %llu without a read marker (%llu of them paired), %llu fused\n",
                static_cast<unsigned long long>(s.robot_sightings), static_cast<unsigned long long>(s.robot_sightings_unidentified),
                static_cast<unsigned long long>(s.robot_sightings_paired), static_cast<unsigned long long>(s.robot_observations_used));
    if (s.closest_approach_m) std::printf("closest approach of two robots: %.3f m\n", *s.closest_approach_m);
    const auto nis = [](const std::optional<double>& mean) {
      char text[32] = "n/a (none fused)";
      if (mean) std::snprintf(text, sizeof text, "%.2f", *mean);
      return std::string(text);
    };
    std::printf("mean NIS of fused observations (about 2 if their covariances are right): landmarks %s, sightings %s\n",
                nis(s.landmark_nis_mean).c_str(), nis(s.sighting_nis_mean).c_str());
    if (!s.coverage.empty()) {
      std::printf("coverage %.3f (of the space the robots can drive through: %.3f), agreement %.3f; time to",
                  s.map.coverage, s.map.drivable_coverage, s.map.agreement);
      for (std::size_t k = 0; k < 4; ++k) {
        if (s.time_to_coverage[k]) {
          std::printf(" %.0f%%: %.0f s", sim::kCoverageLevels[k] * 100, *s.time_to_coverage[k]);
        } else {
          std::printf(" %.0f%%: -", sim::kCoverageLevels[k] * 100);
        }
      }
      std::printf("\n");
    }
    if (s.explore) {
      std::printf("exploration %s", s.explore->explored ? "ended: explored at" : "not ended (duration cap)");
      if (s.explore->explored) std::printf(" %.1f s", s.explore->explored_at_s);
      std::printf("; %llu tasks assigned, %llu timeouts, %llu stuck reports, %llu frontiers given up, %llu plan failures\n",
                  static_cast<unsigned long long>(s.explore->allocator.explore_assigned),
                  static_cast<unsigned long long>(s.explore->allocator.timeouts),
                  static_cast<unsigned long long>(s.explore->allocator.stuck_reports),
                  static_cast<unsigned long long>(s.explore->allocator.frontiers_given_up),
                  static_cast<unsigned long long>(s.explore->driver.plan_failures));
      std::printf("unreachable frontiers: %zu", s.explore->unreachable.size());
      if (s.explore->unreachable_dropped > 0)
        std::printf(" (and %llu clusters the robots could not send)",
                    static_cast<unsigned long long>(s.explore->unreachable_dropped));
      std::printf("\n");
      for (const explore::UnreachableArea& u : s.explore->unreachable) std::printf("  %s\n", explore::describe(u).c_str());
    const auto& a = s.explore->allocator;
    const auto& d = s.explore->driver;
    if (d.visits_taken + d.visits_refused > 0) {
      std::printf("visits: %llu taken, %llu refused by the base's checks; %llu arrived, %llu failed\n",
                  static_cast<unsigned long long>(d.visits_taken), static_cast<unsigned long long>(d.visits_refused),
                  static_cast<unsigned long long>(a.visits_arrived), static_cast<unsigned long long>(a.visits_failed));
    }
    }
    std::printf("%.0f simulated s in %.1f wall s: %.1fx real time, %.0f steps/s\n", s.sim_seconds, s.wall_seconds,
                s.speed_factor, s.steps_per_second);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-sim: a deterministic fleet simulation on simulated time. Each robot runs the production robot\n"
               "pipeline (odometry, local scan matching, features, safety, path following) fed by the LMS2xx\n"
               "emulator's measurement model and wheel encoders with slip; the production base fusion runs in the\n"
               "same process behind a simulated link. The same seed gives identical output files (docs/sim.md)."};
  sim::FleetSimConfig cfg;
  std::string out, robot_config;
  bool json = false;
  double latency_ms = 5;
  app.add_option("--world", cfg.world_path, "world file (the HIL format, docs/hil.md)")->required();
  app.add_option("--robots", cfg.robots, "number of robots (the world's start poses 1..N)")->capture_default_str()->check(CLI::Range(1, 50));
  app.add_option("--duration", cfg.duration_s, "simulated seconds")->capture_default_str()->check(CLI::Range(0.1, 1e6));
  app.add_option("--seed", cfg.seed, "random seed (noise, slip, link loss)")->capture_default_str();
  app.add_option("--out", out, "write trajectories.csv, landmarks.csv, summary.json (and coverage.csv) here");
  app.add_option("--robot-config", robot_config, "the robots' configuration (TOML, as cairn-robot's; default: built-in)");
  app.add_option("--latency-ms", latency_ms, "robot -> base link latency")->capture_default_str()->check(CLI::Range(0.0, 10000.0));
  app.add_option("--loss", cfg.link_loss, "fraction of robot -> base messages lost")->capture_default_str()->check(CLI::Range(0.0, 0.9));
  app.add_flag("--shared-world", cfg.shared_world,
               "one world for all robots: each sees the others' bodies (reflective markers) and collides with them "
               "(the scripted tours are not coordinated: crossing robots stop against each other, counted as bumps)");
  app.add_flag("--map-relative-drift", cfg.robot.localmap.map_relative_drift,
               "robots report as drift only what their error relative to the local map grows by, not each scan's "
               "fused covariance (docs/localmap.md; not the default: with landmarks the base's map turns)");
  bool alone = false;
  app.add_flag("--no-robot-observations", alone,
               "the base ignores robots' sightings of each other: each robot is localised alone (the baseline "
               "cooperative localisation is compared with, docs/markers.md)");
  app.add_flag("--explore", cfg.explore,
               "explore instead of the scripted tours: frontier bids on the base's map, the base's task allocator, "
               "paths on the map; ends when the base reports the world explored or at --duration (docs/explore.md)");
  std::vector<std::string> visits;
  app.add_option("--visit", visits,
                 "T:ROBOT:X:Y: at T simulated s, an operator asks robot ROBOT to visit (X, Y) (global m), as "
                 "cairn-base --visit does; the others cover for it, it rejoins exploration when there or failed "
                 "(repeatable; needs --explore; docs/explore.md)");
  double coverage_period_s = -1;
  app.add_option("--coverage-period", coverage_period_s,
                 "record the map's coverage this often, simulated s (coverage.csv; default 5 with --explore, else off)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--threads", cfg.threads, "worker threads stepping the robots (the output does not depend on it)")
      ->capture_default_str()->check(CLI::Range(1, 64));
  app.add_flag("--json", json, "print the summary as JSON (with wall time and speed factor)");
  CLI11_PARSE(app, argc, argv);
  return run_program("cairn-sim", [&] {
    cfg.link_latency = static_cast<Nanos>(latency_ms * 1e6);
    cfg.robot_observations = !alone;
    if (!visits.empty() && !cfg.explore) throw std::invalid_argument("--visit needs --explore");
    for (const std::string& v : visits) {
      const sim::ScheduledVisit sv = sim::ScheduledVisit::parse(v);
      if (sv.robot > cfg.robots) {
        throw std::invalid_argument("visit '" + v + "': robot " + std::to_string(sv.robot) + " is not in the fleet (--robots " +
                                    std::to_string(cfg.robots) + ": ids 1.." + std::to_string(cfg.robots) + ")");
      }
      if (nanos_to_seconds(sv.at) >= cfg.duration_s) {
        std::fprintf(stderr, "cairn-sim: warning: visit '%s' is due after the run's end (--duration %g)\n", v.c_str(),
                     cfg.duration_s);
      }
      cfg.exploration.visits.push_back(sv);
    }
    if (coverage_period_s < 0) coverage_period_s = cfg.explore ? 5.0 : 0.0;
    cfg.coverage_period = static_cast<Nanos>(coverage_period_s * 1e9);
    if (!robot_config.empty()) {
      const firmware::RobotConfig rc = firmware::load_robot_config(robot_config);
      cfg.robot = rc.executive;
    }
    sim::set_tool_speeds(&cfg);
    return run(cfg, out, json);
  });
}
