// cairn-base: the base station daemon.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <cstring>

#include "basestation/base_config.hpp"
#include "basestation/fleet.hpp"
#include "basestation/fusion_node.hpp"
#include "cairn.h"
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

// `cairn-base --reset-estop ID`: the operator's e-stop reset for one robot, sent as one
// SafetyReset sample (reliable, volatile) once a robot's reader is matched; the robot
// accepts it only when its e-stop reads released (docs/firmware.md, "E-stop").
int reset_estop(const std::string& config_path, int robot) {
  const base::BaseConfig cfg = base::load_base_config(config_path);
  dds::Participant pp(cfg.dds);
  dds::Topic<cairn_SafetyReset> topic(pp);
  dds::Writer<cairn_SafetyReset> writer(pp, topic, dds::state_qos(4));
  if (!writer.wait_for_readers(1, 5 * kNanosPerSecond)) {
    std::fprintf(stderr, "cairn-base: no robot is listening for e-stop resets on this DDS domain (waited 5 s)\n");
    return 1;
  }
  cairn_SafetyReset r{};
  r.robot_id = static_cast<std::uint16_t>(robot);
  r.seq = 1;
  r.issued_ns = MonotonicClock::instance().now();
  dds::set_text(r.issued_by, "cairn-base " + cfg.name);
  if (!writer.write(r)) {
    std::fprintf(stderr, "cairn-base: writing the reset failed: %s\n", dds_strretcode(writer.last_error()));
    return 1;
  }
  // Reliable: wait until every matched reader acknowledged it before the participant goes.
  dds_wait_for_acks(writer.handle(), DDS_SECS(2));
  std::printf("cairn-base: e-stop reset sent to robot %d; it takes effect only if its e-stop is released "
              "(RobotStatus stop reason 8 -> 2 -> 0)\n", robot);
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
  int reset_robot = 0;
  app.add_option("--reset-estop", reset_robot,
                 "send robot ID an e-stop reset (its e-stop latches; it must be released) and exit")
      ->check(CLI::Range(1, 250));
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  if (reset_robot > 0) return run_program("cairn-base", [&] { return reset_estop(config_path, reset_robot); });
  return run_program("cairn-base", [&] { return run(config_path, duration); });
}
