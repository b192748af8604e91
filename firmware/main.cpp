// cairn-robot: the robot executive.
#include <CLI/CLI.hpp>

#include "cairn.h"
#include "common/config.hpp"
#include "common/dds/topics.hpp"
#include "common/log.hpp"
#include "common/program.hpp"
#include "firmware/robot_config.hpp"

using namespace cairn;

namespace {

int run(const std::string& config_path, int id_override, const std::string& name_override, double duration_s) {
  firmware::RobotConfig cfg = firmware::load_robot_config(config_path);
  if (id_override > 0) {
    if (id_override > 250) throw cairn::ConfigError("--id: expected an integer in [1, 250], got " + std::to_string(id_override));
    cfg.id = static_cast<std::uint16_t>(id_override);
    if (name_override.empty()) cfg.name = "robot-" + std::to_string(cfg.id);
  }
  if (!name_override.empty()) cfg.name = name_override;

  logger().start();
  dds::Participant pp(cfg.dds);
  CAIRN_LOG_INFO("robot", "robot {} ({}) starting; DDS {}", cfg.id, cfg.name, pp.describe());

  dds::Topic<cairn_RobotStatus> status_topic(pp);
  dds::QosSpec qos = dds::state_qos();
  qos.liveliness_lease = cfg.liveliness_lease;
  dds::Writer<cairn_RobotStatus> status_writer(pp, status_topic, qos);

  cairn_RobotStatus status{};
  status.robot_id = cfg.id;
  dds::set_text(status.name, cfg.name);
  status.mode = cairn_MODE_IDLE;

  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  const Nanos end = duration_s > 0 ? start + seconds_to_nanos(duration_s) : 0;
  Nanos next = start;
  while (!shutdown_requested() && (end == 0 || clock.now() < end)) {
    status.seq++;
    status.stamp_ns = clock.now();
    status.log_dropped = static_cast<std::uint32_t>(logger().dropped());
    if (!status_writer.write(status)) {
      CAIRN_LOG_WARN("robot", "RobotStatus write failed: {}", dds_strretcode(status_writer.last_error()));
    }
    next += cfg.status_period;
    // Sleep in short steps so a signal ends the program promptly.
    while (!shutdown_requested() && clock.now() < next) clock.sleep_until(std::min(next, clock.now() + 50 * kNanosPerMilli));
  }
  // Tell the base we left on purpose (it shows "left", not "lost").
  status_writer.dispose(status);
  CAIRN_LOG_INFO("robot", "robot {} stopping after {} status messages", cfg.id, status.seq);
  logger().stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-robot: the Cairn robot executive. Publishes the robot's status, odometry, scans and\n"
               "features over DDS and drives the robot. DDS runs on the loopback-only profile unless the\n"
               "configuration's [dds] section says otherwise."};
  std::string config_path;
  int id = 0;
  std::string name;
  double duration = 0;
  app.add_option("-c,--config", config_path, "robot configuration file (TOML), e.g. config/robot.toml")->required();
  app.add_option("--id", id, "override robot.id from the configuration (1..250)");
  app.add_option("--name", name, "override robot.name");
  app.add_option("--duration", duration, "stop after this many seconds (0 = run until SIGINT/SIGTERM)");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-robot", [&] { return run(config_path, id, name, duration); });
}
