// cairn-base: the base station daemon.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>

#include "basestation/base_config.hpp"
#include "basestation/estop_reset.hpp"
#include "basestation/explore_node.hpp"
#include "basestation/fleet.hpp"
#include "basestation/fusion_node.hpp"
#include "basestation/grid_map_node.hpp"
#include "basestation/visit_request.hpp"
#include "basestation/web/foxglove_channels.hpp"
#include "basestation/web/web_page.hpp"
#include "basestation/web/web_server.hpp"
#include "basestation/web/web_state.hpp"
#include "cairn.h"
#include "common/dds/convert.hpp"
#include "common/dds/qos.hpp"
#include "common/dds/topics.hpp"
#include "common/log.hpp"
#include "common/program.hpp"

using namespace cairn;

namespace {

// By reference and read as an int: a hostile status can carry any value in the enum field.
const char* mode_name(const cairn_RobotMode& field) {
  int m = 0;
  static_assert(sizeof field == sizeof m);
  std::memcpy(&m, &field, sizeof m);
  switch (m) {
    case cairn_MODE_BOOTING: return "booting";
    case cairn_MODE_IDLE: return "idle";
    case cairn_MODE_RUNNING: return "running";
    case cairn_MODE_STOPPED: return "stopped";
    case cairn_MODE_FAULT: return "fault";
  }
  return "?";
}

// SIGUSR1: write the map now (docs/mapper.md, "In cairn-base").
std::atomic<bool> g_export_requested{false};
void on_export_signal(int) { g_export_requested.store(true); }

// With exploration on, the unreachable frontiers the robots report are outlined in
// map.png and listed in frontiers.json (docs/explore.md, "Unreachable frontiers").
void export_map(base::GridMapNode& map, const base::FusionNode& fusion, const base::ExploreNode* explore,
                const std::string& dir, const char* why) {
  std::vector<explore::UnreachableArea> unreachable;
  std::vector<mapper::MarkedBox> boxes;
  if (explore) {
    unreachable = explore->allocator().unreachable();
    for (const explore::UnreachableArea& a : unreachable)
      boxes.push_back({a.min_x, a.min_y, a.max_x, a.max_y,
                       a.kind == msg::UnreachableKind::kTooNarrow ? mapper::kTooNarrowRgb : mapper::kDisconnectedRgb});
  }
  std::string error = map.export_to(dir, fusion.fusion(), boxes);
  if (error.empty() && explore) {
    const std::string path = dir + "/frontiers.json";
    std::ofstream f(path);
    f << explore::unreachable_json(unreachable, explore->allocator().unreachable_dropped());
    f.close();
    if (!f) error = path + ": write failed";
  }
  if (error.empty()) {
    CAIRN_LOG_INFO("base", "map exported to {} ({}): map.pgm, map.yaml, map.png, landmarks.json{}", dir.c_str(), why,
                   explore ? ", frontiers.json" : "");
  } else {
    CAIRN_LOG_ERROR("base", "map export to {} failed ({}): {}", dir.c_str(), why, error.c_str());
  }
}

// A bounded IDL string, which a hostile robot may leave unterminated.
template <std::size_t N>
std::string idl_text(const char (&a)[N]) {
  return std::string(a, strnlen(a, N));
}

// Foxglove's timeline is wall time: ns since the Unix epoch.
std::uint64_t wall_clock_ns() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

// The web view's device rows, from the robot's status (bounded by the IDL's MAX_DEVICES).
base::WebRobotStatus web_status(const cairn_RobotStatus& s) {
  base::WebRobotStatus w;
  w.battery_voltage = s.battery_voltage;
  w.battery_soc = s.battery_soc;
  w.stop_reason = s.stop_reason;
  w.stop_text = idl_text(s.stop_text);
  w.nav_state = s.nav_state;
  w.loop_period_mean_us = s.loop_period_mean_us;
  w.loop_period_p99_us = s.loop_period_p99_us;
  w.loop_jitter_max_us = s.loop_jitter_max_us;
  w.loop_cycles = s.loop_cycles;
  w.deadline_misses = s.deadline_misses;
  w.queue_overflows = s.queue_overflows;
  for (std::size_t i = 0; i < std::min<std::size_t>(s.n_devices, cairn_MAX_DEVICES); ++i)
    w.devices.push_back({idl_text(s.devices[i].name), idl_text(s.devices[i].reason), s.devices[i].state});
  return w;
}

constexpr std::string_view kWebIssuer = "web view";
constexpr std::string_view kResetUnderWay = "reset under way";

// A browser's visit request goes where a VisitRequest from DDS goes: the executive's checks
// and allocator (ExploreNode::request_visit), in this thread.
std::string web_visit(const base::WebCommand& v, base::ExploreNode* explore, const base::FusionNode* fusion,
                      const base::GridMapNode* map, Nanos now) {
  if (!explore) return "refused: exploration is off ([explore] enabled = false): no executive to send robots";
  msg::VisitRequest r;
  r.robot_id = v.robot;
  r.issued = now;
  r.x = v.x;
  r.y = v.y;
  std::copy(kWebIssuer.begin(), kWebIssuer.end(), r.issued_by.begin());  // the rest stays zero: terminated
  const base::VisitVerdict verdict = explore->request_visit(r, now, fusion->fusion(), map ? &map->mapper() : nullptr);
  return verdict == base::VisitVerdict::kAccepted ? "accepted" : std::string("refused: ") + base::visit_verdict_text(verdict);
}

// A browser's command, in this thread: a visit, the exploration stopped or started, or an
// e-stop reset started (its result comes later, from the reset node's poll).
std::string web_command(std::uint64_t id, const base::WebCommand& c, base::ExploreNode* explore, const base::FusionNode* fusion,
                        const base::GridMapNode* map, base::EstopResetNode& resets, dds::Writer<cairn_SafetyStop>& stop,
                        std::uint32_t* stop_seq, std::vector<std::pair<std::uint64_t, base::EstopResetResult>>* cancelled, Nanos now) {
  switch (c.kind) {
    case base::WebCommandKind::kVisit: return web_visit(c, explore, fusion, map, now);
    case base::WebCommandKind::kExplore:
      if (!explore) return "refused: exploration is off ([explore] enabled = false)";
      explore->set_running(c.run, now, "the web view");
      return c.run ? "exploration running" : "exploration stopped: robots idle";
    case base::WebCommandKind::kReset: {
      base::EstopResetRequest req;
      req.robot = c.robot;
      req.issued_by = std::string(kWebIssuer);
      std::string why;
      if (!resets.start(id, req, now, &why)) return "refused: " + why;
      CAIRN_LOG_INFO("base", "e-stop reset for robot {} asked by the web view", c.robot);
      return std::string(kResetUnderWay);
    }
    case base::WebCommandKind::kEstopAll: {
      // No reset asked for before the stop may go out after it, and no robot is sent
      // anywhere until the operator starts the exploration again.
      for (const auto& [rid, r] : resets.cancel_all("cancelled by E-STOP ALL")) cancelled->emplace_back(rid, r);
      if (explore) explore->set_running(false, now, "E-STOP ALL from the web view");
      // One sample for every robot (id 0): a robot the base has never heard of stops too.
      msg::SafetyStop m;
      m.robot_id = 0;
      m.seq = ++*stop_seq;
      m.issued = now;
      std::copy(kWebIssuer.begin(), kWebIssuer.end(), m.issued_by.begin());
      cairn_SafetyStop d{};
      dds::to_dds(m, &d);
      const dds_return_t readers = dds_get_matched_subscriptions(stop.handle(), nullptr, 0);
      if (!stop.write(d)) return std::string("failed: ") + dds_strretcode(stop.last_error());
      CAIRN_LOG_WARN("base", "remote e-stop of every robot #{} asked by the web view ({} robot reader(s) matched)", m.seq, readers);
      return "e-stop sent to every robot (" + std::to_string(readers < 0 ? 0 : readers) +
             " robot reader(s) matched): each latches until a reset";
    }
  }
  return "refused: unknown command";
}

int run(const std::string& config_path, double duration_s) {
  const base::BaseConfig cfg = base::load_base_config(config_path);
  // A file-size limit must give EFBIG (counted, the fusion goes on in memory), not kill the base.
  std::signal(SIGXFSZ, SIG_IGN);
  logger().start();
  // SIGUSR1 asks for a map export; installed before anything slow, so the signal never
  // takes its default action (terminating the base), also when the mapper is off.
  static_assert(std::atomic<bool>::is_always_lock_free);
  struct sigaction sa {};
  sa.sa_handler = on_export_signal;
  sa.sa_flags = SA_RESTART;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, nullptr);
  dds::Participant pp(cfg.dds);
  CAIRN_LOG_INFO("base", "base station '{}' starting; DDS {}", cfg.name, pp.describe());

  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  const bool tty = isatty(STDOUT_FILENO) != 0;
  std::unique_ptr<base::FusionNode> fusion;
  base::FleetAdmission admission;
  for (const auto& [id, prior] : cfg.fusion.robots) admission.listed.insert(id);
  admission.max_unlisted = cfg.fusion.max_unknown_robots;
  admission.admitted = [&fusion](std::uint16_t id) { return fusion && fusion->fusion().admitted(id); };
  base::Fleet fleet(
      cfg.stale_after,
      [&](const std::string& event) {
        std::printf("[%8.3f] fleet: %s\n", nanos_to_seconds(clock.now() - start), event.c_str());
        std::fflush(stdout);
      },
      admission);

  dds::Topic<cairn_RobotStatus> status_topic(pp);
  // The reader requests no particular lease: any robot's offered lease is accepted
  // and enforced, and a robot whose lease expires shows up as "no writers".
  dds::Reader<cairn_RobotStatus> status_reader(pp, status_topic, dds::state_qos(1));

  if (cfg.fusion_enabled) {
    fusion = std::make_unique<base::FusionNode>(pp, cfg);
    CAIRN_LOG_INFO("base", "fusion: {}", fusion->restore());
  }
  // The central map needs the fusion: each scan is placed by its estimate of the robot.
  std::unique_ptr<base::GridMapNode> map;
  if (fusion && cfg.mapper_enabled) {
    map = std::make_unique<base::GridMapNode>(pp, cfg);
    CAIRN_LOG_INFO("base", "map: {} x {} tiles of {} cells; kill -USR1 {} writes it to {}", map->tiles_x(), map->tiles_y(),
                   cairn_TILE_CELLS, static_cast<long long>(getpid()), cfg.map_export_dir.c_str());
  }

  std::unique_ptr<base::ExploreNode> explore;
  if (fusion && cfg.explore_enabled) {
    explore = std::make_unique<base::ExploreNode>(pp, cfg.explore);
    CAIRN_LOG_INFO("base", "explore: assigning frontiers from the robots' bids ({})",
                   cfg.explore.coordinated ? "coordinated" : "uncoordinated");
  }

  std::unique_ptr<base::WebServer> web;
  base::WebState web_state;
  if (cfg.web.enabled) {
    base::WebServerOptions o;
    o.listen = cfg.web.listen;
    o.port = cfg.web.port;
    o.token = cfg.web.token;
    o.index_html = base::web_page::kIndexHtml;
    o.app_js = base::web_page::kAppJs;
    web = std::make_unique<base::WebServer>(o);
    CAIRN_LOG_INFO("base", "web view: http://{}:{}/?token=... (the token is [web] token)", cfg.web.listen.c_str(), web->port());
    std::printf("web view listening on %s port %u\n", cfg.web.listen.c_str(), static_cast<unsigned>(web->port()));
    std::fflush(stdout);
  }
  Nanos next_web_state = start, next_web_map = start;
  std::optional<base::EstopResetNode> resets;  // the web view's e-stop resets, run without blocking this loop
  std::optional<dds::Topic<cairn_SafetyStop>> stop_topic;
  std::optional<dds::Writer<cairn_SafetyStop>> stop_writer;  // the web view's e-stop of every robot
  std::uint32_t stop_seq = 0;
  if (web) {
    resets.emplace(pp);
    stop_topic.emplace(pp);
    stop_writer.emplace(pp, *stop_topic, dds::state_qos(4));  // volatile, as the robots read it
  }
  std::map<std::uint64_t, base::WebCommand> reset_commands;  // by command id, while under way
  base::WebMapTiles web_tiles;  // the map for the page, in tiles sent where they changed
  std::uint64_t foxglove_map_version = 0;
  base::FoxgloveChannels foxglove;  // the same state and map for Foxglove clients (docs/web-view.md)

  const Nanos end = duration_s > 0 ? start + seconds_to_nanos(duration_s) : 0;
  Nanos next_table = start + cfg.table_period;
  while (!shutdown_requested() && (end == 0 || clock.now() < end)) {
    status_reader.wait(20 * kNanosPerMilli);
    const Nanos now = clock.now();
    if (fusion) fusion->poll(now);
    if (map) map->poll(now, fusion->fusion());
    if (g_export_requested.exchange(false)) {
      if (map) export_map(*map, *fusion, explore.get(), cfg.map_export_dir, "SIGUSR1");
      else CAIRN_LOG_WARN("base", "map export requested (SIGUSR1) but the central map is off ([fusion] and [mapper] enabled = true)");
    }
    status_reader.take(
        [&](const cairn_RobotStatus& s, const dds_sample_info_t& info) {
          fleet.on_status(s.robot_id, s.name, mode_name(s.mode), s.seq, now);
          if (resets && !resets->idle()) resets->on_status(status_reader.handle(), s, info, now);
          if (web && fleet.robots().contains(s.robot_id)) web_state.on_status(s.robot_id, web_status(s));
          if (explore) explore->on_nav(s.robot_id, s.nav_state, s.nav_task_id, now);  // a stuck robot: its task back at once
        },
        [&](const cairn_RobotStatus& key, dds::InstanceEvent ev) {
          if (ev == dds::InstanceEvent::kDisposed) {
            fleet.on_left(key.robot_id, now);
          } else {
            fleet.on_lost(key.robot_id, now);
          }
        });
    fleet.tick(now);
    if (explore && explore->poll(now, fusion->fusion(), fleet, map ? &map->mapper() : nullptr) && map) {
      // Exploration just ended: save the map without being asked, and say what it covered
      // (after the export, which re-renders it: the area is that of the map written).
      export_map(*map, *fusion, explore.get(), cfg.map_export_dir, "exploration complete");
      const base::GridMapNode::Area a = map->area();
      CAIRN_LOG_INFO("explore", "explored: {:.1f} m2 mapped ({:.1f} m2 clear, {:.1f} m2 obstacle)", a.clear_m2 + a.obstacle_m2,
                     a.clear_m2, a.obstacle_m2);
    }
    if (web) {
      for (const base::QueuedWebCommand& c : web->take_commands()) {
        std::vector<std::pair<std::uint64_t, base::EstopResetResult>> cancelled;
        std::string result =
            web_command(c.id, c.command, explore.get(), fusion.get(), map.get(), *resets, *stop_writer, &stop_seq, &cancelled, now);
        if (result == kResetUnderWay) reset_commands.emplace(c.id, c.command);
        web_state.on_command_result(c.id, c.command, std::move(result));
        for (const auto& [id, r] : cancelled) {
          const auto it = reset_commands.find(id);
          if (it == reset_commands.end()) continue;
          web_state.on_command_result(id, it->second, "cancelled: " + r.message);
          reset_commands.erase(it);
        }
      }
      for (const auto& [id, result] : resets->poll(now)) {
        CAIRN_LOG_INFO("base", "web view e-stop reset: {}", result.message);
        const auto it = reset_commands.find(id);
        if (it == reset_commands.end()) continue;
        web_state.on_command_result(id, it->second, (result.ok() ? "done: " : "failed: ") + result.message);
        reset_commands.erase(it);
      }
      if (map && now >= next_web_map) {
        next_web_map = now + cfg.web.map_period;
        const auto tiles = web_tiles.update(map->mapper().classified());
        web->publish_map(tiles);
        if (tiles->version != foxglove_map_version) {  // Foxglove's grid goes whole: only when the map changed
          foxglove_map_version = tiles->version;
          foxglove.set_map(map->mapper().classified(), wall_clock_ns());
        }
      }
      if (now >= next_web_state) {
        next_web_state = now + cfg.web.state_period;
        const base::Fusion* f = fusion ? &fusion->fusion() : nullptr;
        auto state = std::make_shared<const std::string>(web_state.state_json(now, fleet, f, explore ? &explore->allocator() : nullptr));
        web->publish_state(state);
        web->publish_foxglove(foxglove.snapshot(fleet, f, std::move(state), wall_clock_ns()));  // the same text on /cairn/state
      }
    }
    if (now >= next_table) {
      next_table += cfg.table_period;
      if (tty) std::printf("\033[2J\033[H");
      // A robot may write only in its own partition (docs/security.md): a sample keyed to
      // another robot is one posing as it, dropped by the reader of its topic.
      const std::uint64_t foreign = status_reader.foreign_samples() + (fusion ? fusion->foreign_samples() : 0) +
                                    (map ? map->foreign_samples() : 0) + (explore ? explore->foreign_samples() : 0);
      std::printf("[%8.3f] fleet: %zu alive, %llu status(es) of unlisted robots refused, %llu sample(s) of another robot's id "
                  "dropped\n%s",
                  nanos_to_seconds(now - start), fleet.alive_count(), static_cast<unsigned long long>(fleet.refused()),
                  static_cast<unsigned long long>(foreign), fleet.table(now).c_str());
      if (fusion) std::printf("[%8.3f] %s\n%s", nanos_to_seconds(now - start), fusion->summary().c_str(), fusion->robot_lines().c_str());
      if (map) std::printf("[%8.3f] %s\n", nanos_to_seconds(now - start), map->summary().c_str());
      if (explore) std::printf("[%8.3f] %s\n", nanos_to_seconds(now - start), explore->summary().c_str());
      std::fflush(stdout);
    }
  }
  if (fusion)
    std::printf("[%8.3f] final %s\n%s", nanos_to_seconds(clock.now() - start), fusion->summary().c_str(),
                fusion->robot_lines("final ").c_str());
  if (map) {
    export_map(*map, *fusion, explore.get(), cfg.map_export_dir, "exit");
    std::printf("[%8.3f] final %s\n", nanos_to_seconds(clock.now() - start), map->summary().c_str());
  }
  CAIRN_LOG_INFO("base", "base station stopping");
  logger().stop();
  return 0;
}

// `cairn-base --reset-estop ID`: the operator's e-stop reset for one robot, delivered to
// that robot's reader and confirmed by its status (basestation/estop_reset.hpp); the
// robot accepts it only when its e-stop reads released (docs/firmware.md, "E-stop").
int reset_estop(const std::string& config_path, int robot) {
  const base::BaseConfig cfg = base::load_base_config(config_path);
  dds::Participant pp(cfg.dds);
  base::EstopResetRequest req;
  req.robot = static_cast<std::uint16_t>(robot);
  req.issued_by = "cairn-base " + cfg.name;
  const base::EstopResetResult r = base::reset_estop(pp, req);
  std::fprintf(r.ok() ? stdout : stderr, "cairn-base: %s\n", r.message.c_str());
  return r.ok() ? 0 : 1;
}

// `cairn-base --visit R X Y`: the operator asks robot R to visit (X, Y) in the global
// frame; delivered to the running base's executive and confirmed by the robot's new task
// (basestation/visit_request.hpp).
int visit(const std::string& config_path, const std::vector<double>& args) {
  const base::BaseConfig cfg = base::load_base_config(config_path);
  dds::Participant pp(cfg.dds);
  base::VisitRequestOptions o;
  o.robot = static_cast<std::uint16_t>(args[0]);
  o.target = Vec2(args[1], args[2]);
  o.issued_by = "cairn-base " + cfg.name;
  const base::VisitResult r = base::request_visit(pp, o);
  std::fprintf(r.ok() ? stdout : stderr, "cairn-base: %s\n", r.message.c_str());
  return r.ok() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-base: the Cairn base station. Watches the fleet over DDS and prints a live table of\n"
               "robots (id, name, mode, state, last seen); fuses every robot's odometry and features (CCML) and\n"
               "publishes corrections and the landmark map; builds the global occupancy map from the robots'\n"
               "scans and publishes its changed tiles (MapTile). SIGUSR1 writes the map (PGM + YAML for\n"
               "map_server, PNG, landmarks JSON) to [mapper] export_dir; so does every exit. DDS runs on the\n"
               "loopback-only profile unless the configuration's [dds] section says otherwise."};
  std::string config_path;
  double duration = 0;
  app.add_option("-c,--config", config_path, "base-station configuration file (TOML), e.g. config/base.toml")->required();
  app.add_option("--duration", duration, "stop after this many seconds (0 = run until SIGINT/SIGTERM)");
  int reset_robot = 0;
  app.add_option("--reset-estop", reset_robot,
                 "send robot ID an e-stop reset (its e-stop latches; it must be released) and exit")
      ->check(CLI::Range(1, 250));
  std::vector<double> visit_args;
  app.add_option("--visit", visit_args,
                 "ask the running base to send robot ID to X Y (global frame, m) now: its exploration task ends, the "
                 "others cover for it, it rejoins exploration when it arrives or fails; waits for the robot's new task "
                 "and exits (0: assigned)")
      ->expected(3)
      ->type_name("ID X Y")
      ->excludes("--reset-estop");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  if (reset_robot > 0) return run_program("cairn-base", [&] { return reset_estop(config_path, reset_robot); });
  if (!visit_args.empty()) {
    const double id = visit_args[0];
    if (!(id >= 1 && id <= 65535 && id == std::floor(id)) || !std::isfinite(visit_args[1]) || !std::isfinite(visit_args[2])) {
      std::fprintf(stderr, "cairn-base: --visit ID X Y: ID an integer 1..65535, X and Y finite metres\n");
      return 2;
    }
    return run_program("cairn-base", [&] { return visit(config_path, visit_args); });
  }
  return run_program("cairn-base", [&] { return run(config_path, duration); });
}
