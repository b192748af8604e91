// cairn-robot: the robot executive. With a [devices] section it runs the drivers, the RT
// loop and the local mapper (firmware/executive) and bridges them to DDS; without one it
// is a status-only fleet member (no hardware).
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <random>

#include "common/config.hpp"
#include "common/log.hpp"
#include "common/program.hpp"
#include "firmware/executive/devices.hpp"
#include "firmware/nav_monitor.hpp"
#include "firmware/navigator.hpp"
#include "firmware/robot_bridge.hpp"
#include "firmware/robot_config.hpp"
#include "firmware/service_notify.hpp"

using namespace cairn;

namespace {

// The local e-stop reset: SIGUSR1 (`systemctl kill -s USR1 cairn-robot`, or
// `kill -USR1 PID`) counts one reset request; the main loop hands each to the executive.
std::atomic<std::uint32_t> g_local_resets{0};
extern "C" void on_reset_signal(int) { g_local_resets.fetch_add(1); }

void install_reset_handler() {
  struct sigaction sa{};
  sa.sa_handler = on_reset_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, nullptr);
}

std::string describe(const firmware::RobotConfig& c) {
  std::string s = "robot " + std::to_string(c.id) + " (" + c.name + ")";
  if (!c.has_devices) return s + ": status only (no [devices] section)";
  const auto& e = c.executive;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                ": laser %s, drives %s (nodes %d, %d), power %s; RT period %.1f ms; scans every %d to the base; "
                "%zu waypoint(s); link timeout %.1f s",
                e.lms_uri.c_str(), e.can_uri.c_str(), e.master.nodes[0], e.master.nodes[1], e.power_uri.c_str(),
                nanos_to_seconds(e.period) * 1e3, e.scan_publish_every, c.motion.waypoints.size(),
                nanos_to_seconds(e.safety.link_timeout));
  return s + buf;
}

void log_progress(const firmware::RobotConfig& cfg, firmware::Executive& exec, const firmware::RobotBridge& bridge) {
  const firmware::RtSnapshot r = exec.rt_snapshot();
  const auto& n = bridge.counters();
  char line[400];
  std::snprintf(line, sizeof line,
                "robot %u: %s; local pose %.2f %.2f %.1f deg; scans %llu (matched %llu); loop p99 %.0f us, jitter max %.0f us, "
                "misses %llu; sent odometry %llu, features %llu, scans %llu; corrections %llu; global map %zu tiles "
                "(%llu out of room)",
                cfg.id, firmware::stop_reason_text(r.stop), r.local_pose.x, r.local_pose.y, r.local_pose.theta * 57.29578,
                static_cast<unsigned long long>(r.scans), static_cast<unsigned long long>(r.matched),
                static_cast<double>(r.period_p99_us), static_cast<double>(r.jitter_max_us),
                static_cast<unsigned long long>(r.misses), static_cast<unsigned long long>(n.odometry),
                static_cast<unsigned long long>(n.features), static_cast<unsigned long long>(n.lasers),
                static_cast<unsigned long long>(n.corrections), bridge.global_map().tiles(),
                static_cast<unsigned long long>(bridge.global_map().counters().out_of_room));
  CAIRN_LOG_INFO("robot", "{}", std::string_view(line));
}

int run(const std::string& config_path, int id_override, const std::string& name_override, double duration_s,
        bool check_only) {
  firmware::RobotConfig cfg = firmware::load_robot_config(config_path);
  if (id_override > 0) {
    if (id_override > 250) throw cairn::ConfigError("--id: expected an integer in [1, 250], got " + std::to_string(id_override));
    cfg.id = static_cast<std::uint16_t>(id_override);
    cfg.executive.robot_id = cfg.id;
    if (name_override.empty()) cfg.name = "robot-" + std::to_string(cfg.id);
  }
  if (!name_override.empty()) cfg.name = name_override;
  if (check_only) {
    std::printf("%s: OK\n%s\n", config_path.c_str(), describe(cfg).c_str());
    return 0;
  }

  cfg.executive.boot_epoch = std::random_device{}();  // a restart is a new epoch at the base
  logger().start();
  dds::Participant pp(cfg.dds);
  // Two lines: the logger keeps 192 characters of each.
  CAIRN_LOG_INFO("robot", "{}", describe(cfg));
  CAIRN_LOG_INFO("robot", "robot {}: DDS {}", cfg.id, pp.describe());
  firmware::RobotBridge bridge(pp, cfg);
  auto& clock = MonotonicClock::instance();
  std::unique_ptr<firmware::Executive> exec;
  if (cfg.has_devices) {
    firmware::ExecutiveDevices devices =
        firmware::open_devices(cfg.executive, clock, [] { return !shutdown_requested(); });
    exec = std::make_unique<firmware::Executive>(cfg.executive, clock, std::move(devices));
    exec->start();
  }
  // An exploring robot goes where the base's tasks send it: no scripted route.
  firmware::MotionConfig motion = cfg.motion;
  if (cfg.explore.enabled) motion.waypoints.clear();
  firmware::Navigator nav(motion);
  firmware::ServiceNotifier service;
  std::uint64_t status_loops = 0;
  service.ready(describe(cfg));
  if (service.watchdog_enabled()) {
    CAIRN_LOG_INFO("robot", "systemd watchdog every {:.1f} s, fed while the RT loop cycles",
                   nanos_to_seconds(service.watchdog_interval()));
  }

  const Nanos start = clock.now();
  // Exploration ([explore] enabled): bids and plans on the base's map, on this thread.
  std::unique_ptr<firmware::RobotExplorer> explorer;
  auto bid = std::make_unique<msg::Bid>();
  auto route = std::make_unique<msg::TaskAssignment>();
  if (exec && cfg.explore.enabled) {
    explorer = std::make_unique<firmware::RobotExplorer>(cfg.explore, cfg.id, cfg.global_map.max_cells);
    CAIRN_LOG_INFO("robot", "explore: bidding every {} s on a map of up to {} cells", nanos_to_seconds(cfg.explore.bid_period),
                   cfg.global_map.max_cells);
  }
  // The base's current task as the robot took it, for the stuck report in RobotStatus.
  firmware::NavMonitor nav_monitor(cfg.nav_monitor);
  std::uint32_t base_task = 0;
  bool base_task_moves = false;
  const Nanos end = duration_s > 0 ? start + seconds_to_nanos(duration_s) : 0;
  const Nanos tick = exec ? cfg.bridge_period : 50 * kNanosPerMilli;
  Nanos next_status = start, next_progress = start + 10 * kNanosPerSecond, next = start;
  std::uint32_t local_resets = g_local_resets.load();
  while (!shutdown_requested() && (end == 0 || clock.now() < end)) {
    const Nanos now = clock.now();
    bridge.take_stops(exec.get());   // the base's SafetyStop (first: a reset in the same tick is refused)
    bridge.take_resets(exec.get());  // the base's SafetyReset
    bridge.take_map_tiles();         // the base's global map, kept for the bids
    if (const std::uint32_t r = g_local_resets.load(); r != local_resets) {
      local_resets = r;
      CAIRN_LOG_INFO("robot", "e-stop reset requested locally (SIGUSR1)");
      if (exec) exec->request_reset();
    }
    if (exec) {
      bridge.forward(*exec);
      const bool heard = bridge.poll_inputs([&](const msg::TaskAssignment& t) {
        base_task = t.task_id;
        base_task_moves = msg::task_moves(t.kind);
        if (explorer) explorer->on_task(t);
        // An exploring robot plans the base's target itself (next step below).
        const bool planned_here = explorer && t.n_path == 0 && msg::task_moves(t.kind);
        if (planned_here) return;
        const std::string why = nav.on_task(t, bridge.local_to_global());
        if (!why.empty()) CAIRN_LOG_WARN("robot", "{}", why);
      });
      if (heard) exec->note_link(now);
      if (explorer && bridge.local_to_global()) {
        const auto snap = exec->rt_snapshot();
        const Pose2 global = compose(*bridge.local_to_global(), snap.local_pose);
        explorer->on_safety(snap.stop, snap.field_nearest, global, now);  // held by the field: mark and replan
        const auto step = explorer->step(bridge.global_map(), global, now, bid.get(), route.get());
        if (step.bid) bridge.publish_bid(*bid);
        if (step.route) {
          const std::string why = nav.on_task(*route, bridge.local_to_global(), /*replan=*/true);
          if (!why.empty()) CAIRN_LOG_WARN("robot", "{}", why);
        }
      }
      double v = 0, w = 0;
      const auto rt = exec->rt_snapshot();
      nav.command(rt.local_pose, rt.v, &v, &w);
      const NavState was = nav_monitor.state();
      // Done with the path of the base's task (arrived; the base has not yet sent another):
      // not stuck. A plan that failed leaves the task unfinished (the explorer stood it);
      // a robot that yields to keep right is not stuck either.
      const bool arrived = nav.task_id() == base_task && nav.finished();
      const bool yielding = explorer && explorer->yielding();
      const NavState ns =
          nav_monitor.update(base_task, base_task_moves && !arrived && !yielding, rt.stop, rt.local_pose.translation(), now);
      bridge.set_nav(ns, base_task);
      if (ns == NavState::kStuck && was != NavState::kStuck) {
        CAIRN_LOG_WARN("robot", "robot {} stuck on task {}: no progress for {:.1f} s (stop: {}); reported to the base", cfg.id,
                       base_task, nanos_to_seconds(cfg.nav_monitor.stuck_after), stop_reason_text(rt.stop));
      }
      exec->set_velocity(v, w, clock.now());  // not `now`: a bid or a plan may have taken milliseconds
      service.alive(exec->rt_snapshot().cycles, now);
      if (now >= next_progress) {
        next_progress += 10 * kNanosPerSecond;
        log_progress(cfg, *exec, bridge);
        if (explorer) {
          const auto& x = explorer->counters();
          CAIRN_LOG_INFO("robot", "robot {} explore: bids {} (no frontier {}, failed {}), plans {} (failed {}, cut {}), blocks marked {}",
                         cfg.id, x.bids, x.bids_no_frontier, x.bids_failed, x.plans, x.plan_failures, x.paths_cut,
                         x.blocked_marks);
          if (x.yields > 0) CAIRN_LOG_INFO("robot", "robot {} explore: stood {} times to keep right", cfg.id, x.yields);
        }
      }
    }
    if (!exec) service.alive(++status_loops, now);  // status-only: no RT loop to watch
    if (now >= next_status) {
      next_status += cfg.status_period;
      bridge.publish_status(exec.get(), now);
    }
    if (next <= now) next = now + tick;  // an early wake keeps the tick; a stall does not burst
    if (exec) {
      // Woken by the RT thread as soon as it queues a message (a scan's OdometryIncrement
      // goes out at once), else at the next tick for inputs and status.
      const std::uint32_t seen = exec->output_event().value();
      if (!exec->has_output()) clock.wait_event(exec->output_event(), seen, next);
    } else {
      clock.sleep_until(next);
    }
  }
  service.stopping();
  if (exec) {
    exec->stop();
    bridge.forward(*exec);
    for (const std::string& r : exec->rt_reports()) CAIRN_LOG_INFO("robot", "{}", r);
    log_progress(cfg, *exec, bridge);
  }
  bridge.dispose();
  CAIRN_LOG_INFO("robot", "robot {} stopping after {} status messages", cfg.id, bridge.counters().statuses);
  logger().stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-robot: the Cairn robot executive. Runs the laser, drive and power-board drivers, odometry,\n"
               "local scan matching, feature extraction and safety in a real-time loop, and publishes the\n"
               "robot's status, odometry, scans and features over DDS (docs/firmware.md). DDS runs on the\n"
               "loopback-only profile unless the configuration's [dds] section says otherwise.\n"
               "The e-stop latches: after release, reset with SIGUSR1 (kill -USR1 PID), the base's SafetyReset\n"
               "topic or the power board's reset input."};
  std::string config_path;
  int id = 0;
  std::string name;
  double duration = 0;
  bool check = false;
  app.add_option("-c,--config", config_path, "robot configuration file (TOML), e.g. config/robot.toml")->required();
  app.add_option("--id", id, "override robot.id from the configuration (1..250)");
  app.add_option("--name", name, "override robot.name");
  app.add_option("--duration", duration, "stop after this many seconds (0 = run until SIGINT/SIGTERM)");
  app.add_flag("--check-config", check, "validate the configuration, print what it would run, and exit");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  install_reset_handler();
  return run_program("cairn-robot", [&] { return run(config_path, id, name, duration, check); });
}
