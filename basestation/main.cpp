// cairn-base: the base station daemon.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>

#include "basestation/base_config.hpp"
#include "basestation/fleet.hpp"
#include "basestation/fusion_node.hpp"
#include "cairn.h"
#include "common/dds/topics.hpp"
#include "common/log.hpp"
#include "common/program.hpp"

using namespace cairn;

namespace {

const char* mode_name(cairn_RobotMode m) {
  switch (m) {
    case cairn_MODE_BOOTING: return "booting";
    case cairn_MODE_IDLE: return "idle";
    case cairn_MODE_RUNNING: return "running";
    case cairn_MODE_STOPPED: return "stopped";
    case cairn_MODE_FAULT: return "fault";
  }
  return "?";
}

int run(const std::string& config_path, double duration_s) {
  const base::BaseConfig cfg = base::load_base_config(config_path);
  // A file-size limit must give EFBIG (counted, the fusion goes on in memory), not kill the base.
  std::signal(SIGXFSZ, SIG_IGN);
  logger().start();
  dds::Participant pp(cfg.dds);
  CAIRN_LOG_INFO("base", "base station '{}' starting; DDS {}", cfg.name, pp.describe());

  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  const bool tty = isatty(STDOUT_FILENO) != 0;
  base::Fleet fleet(cfg.stale_after, [&](const std::string& event) {
    std::printf("[%8.3f] fleet: %s\n", nanos_to_seconds(clock.now() - start), event.c_str());
    std::fflush(stdout);
  });

  dds::Topic<cairn_RobotStatus> status_topic(pp);
  // The reader requests no particular lease: any robot's offered lease is accepted
  // and enforced, and a robot whose lease expires shows up as "no writers".
  dds::Reader<cairn_RobotStatus> status_reader(pp, status_topic, dds::state_qos(1));

  std::unique_ptr<base::FusionNode> fusion;
  if (cfg.fusion_enabled) {
    fusion = std::make_unique<base::FusionNode>(pp, cfg);
    CAIRN_LOG_INFO("base", "fusion: {}", fusion->restore());
  }

  const Nanos end = duration_s > 0 ? start + seconds_to_nanos(duration_s) : 0;
  Nanos next_table = start + cfg.table_period;
  while (!shutdown_requested() && (end == 0 || clock.now() < end)) {
    status_reader.wait(20 * kNanosPerMilli);
    const Nanos now = clock.now();
    if (fusion) fusion->poll(now);
    status_reader.take(
        [&](const cairn_RobotStatus& s, const dds_sample_info_t&) {
          fleet.on_status(s.robot_id, s.name, mode_name(s.mode), s.seq, now);
        },
        [&](const cairn_RobotStatus& key, dds::InstanceEvent ev) {
          if (ev == dds::InstanceEvent::kDisposed) {
            fleet.on_left(key.robot_id, now);
          } else {
            fleet.on_lost(key.robot_id, now);
          }
        });
    fleet.tick(now);
    if (now >= next_table) {
      next_table += cfg.table_period;
      if (tty) std::printf("\033[2J\033[H");
      std::printf("[%8.3f] fleet: %zu alive\n%s", nanos_to_seconds(now - start), fleet.alive_count(),
                  fleet.table(now).c_str());
      if (fusion) std::printf("[%8.3f] %s\n", nanos_to_seconds(now - start), fusion->summary().c_str());
      std::fflush(stdout);
    }
  }
  if (fusion) std::printf("[%8.3f] final %s\n", nanos_to_seconds(clock.now() - start), fusion->summary().c_str());
  CAIRN_LOG_INFO("base", "base station stopping");
  logger().stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-base: the Cairn base station. Watches the fleet over DDS and prints a live table of\n"
               "robots (id, name, mode, state, last seen). DDS runs on the loopback-only profile unless the\n"
               "configuration's [dds] section says otherwise."};
  std::string config_path;
  double duration = 0;
  app.add_option("-c,--config", config_path, "base-station configuration file (TOML), e.g. config/base.toml")->required();
  app.add_option("--duration", duration, "stop after this many seconds (0 = run until SIGINT/SIGTERM)");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-base", [&] { return run(config_path, duration); });
}
