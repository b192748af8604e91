// cairn-hil: the hardware-in-the-loop bench.
//   cairn-hil lms     serves an emulated SICK LMS2xx over a pty or TCP, scanning a world
//                     from a fixed pose, until interrupted.
//   cairn-hil robots  serves whole robots (laser, two CiA 402 drives, power board, body
//                     physics) in a world, writes each robot's cairn-robot configuration,
//                     logs ground truth and injects scheduled device faults.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <sstream>

#include "common/program.hpp"
#include "hil/bench/fleet_bench.hpp"
#include "hil/lms2xx/lms_server.hpp"

using namespace cairn;

namespace {

void sleep_while_running(Nanos until) {
  auto& clock = MonotonicClock::instance();
  while (!shutdown_requested() && clock.now() < until) clock.sleep_until(std::min(until, clock.now() + 50 * kNanosPerMilli));
}

int run_lms(const std::string& world_path, const std::string& pose_text, int tcp_port, double noise, double boot) {
  const hil::World world = hil::World::load(world_path);
  Pose2 pose;
  char c1 = 0, c2 = 0;
  std::istringstream ps(pose_text);
  if (!(ps >> pose.x >> c1 >> pose.y >> c2 >> pose.theta) || c1 != ',' || c2 != ',') {
    throw std::runtime_error("--pose: expected x,y,theta, got '" + pose_text + "'");
  }
  hil::LmsDeviceConfig cfg;
  cfg.range_noise_m = noise;
  cfg.boot_time_s = boot;
  hil::LmsServer server(tcp_port >= 0 ? hil::LmsServer::Link::kTcp : hil::LmsServer::Link::kPty, cfg, &world,
                        [pose](Nanos) { return pose; }, std::max(tcp_port, 0));
  server.start();
  std::printf("cairn-hil: LMS2xx emulator at %s (world %s, pose %.2f,%.2f,%.2f)\n", server.uri().c_str(),
              world_path.c_str(), pose.x, pose.y, pose.theta);
  std::fflush(stdout);
  while (!shutdown_requested()) sleep_while_running(MonotonicClock::instance().now() + kNanosPerSecond);
  server.with_device([](hil::LmsDevice& d) {
    const auto& c = d.counters();
    std::printf("cairn-hil: %llu requests, %llu scans sent, %llu dropped (line busy), %llu baud changes\n",
                static_cast<unsigned long long>(c.requests), static_cast<unsigned long long>(c.scans_sent),
                static_cast<unsigned long long>(c.scans_dropped_busy), static_cast<unsigned long long>(c.baud_changes));
    return 0;
  });
  server.stop();
  return 0;
}

struct RobotsOptions {
  std::string world = "hil/worlds/office.world";
  std::vector<int> ids;
  int count = 1;
  std::string robot_template = "config/robot-hil.toml";
  std::string out_dir = "hil-run";
  std::string truth_path;
  std::vector<std::string> faults;
  double duration = 0, report_period = 5.0;
  bool lms_tcp = false;
  bool shared_world = false;
  std::string can_iface, lms_uart, lms_host_uri;
  std::uint32_t lms_uart_baud = 38400;
};

int run_robots(const RobotsOptions& o) {
  const hil::World world = hil::World::load(o.world);
  hil::FleetBenchConfig cfg;
  cfg.robots = o.ids;
  if (cfg.robots.empty()) {
    for (int i = 1; i <= o.count; ++i) cfg.robots.push_back(i);
  }
  cfg.robot_template = o.robot_template;
  cfg.out_dir = o.out_dir;
  cfg.lms_tcp = o.lms_tcp;
  cfg.can_iface = o.can_iface;
  cfg.lms_uart = o.lms_uart;
  cfg.lms_host_uri = o.lms_host_uri;
  cfg.lms_uart_baud = o.lms_uart_baud;
  cfg.shared_world = o.shared_world;
  for (const std::string& f : o.faults) cfg.faults.push_back(hil::ScheduledFault::parse(f));
  hil::FleetBench fleet(world, cfg);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> truth(nullptr, &std::fclose);
  if (!o.truth_path.empty()) {
    truth.reset(std::fopen(o.truth_path.c_str(), "w"));
    if (!truth) throw std::runtime_error("--truth: cannot write " + o.truth_path);
    std::fprintf(truth.get(), "# t_s robot x y theta odometer_m (world frame, ground truth)\n");
  }
  fleet.start();
  const std::vector<std::string> paths = fleet.write_robot_configs();
  for (std::size_t i = 0; i < fleet.size(); ++i) {
    std::printf("cairn-hil: robot %d: laser %s, drives %s, power %s, %zu route waypoint(s) -> %s\n", fleet.id(i),
                fleet.bench(i).lms_uri().c_str(), fleet.bench(i).can_uri().c_str(), fleet.bench(i).power_uri().c_str(),
                fleet.local_route(i).size(), paths[i].c_str());
  }
  std::printf("cairn-hil: ready: %zu robot(s) in %s; start each with cairn-robot --config <file above>\n", fleet.size(),
              o.world.c_str());
  std::fflush(stdout);

  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  // t_s = 0 on CLOCK_MONOTONIC, which the robots stamp their scans with on this machine: a
  // trajectory in robot time (the base's trajectories.csv) can be scored against the truth.
  if (truth) std::fprintf(truth.get(), "# t0_monotonic_ns %lld\n", static_cast<long long>(start));
  Nanos next = start, next_report = start + seconds_to_nanos(o.report_period);
  while (!shutdown_requested() && (o.duration <= 0 || clock.now() < start + seconds_to_nanos(o.duration))) {
    const Nanos now = clock.now();
    const double t = nanos_to_seconds(now - start);
    for (const std::string& line : fleet.apply_faults(t)) std::printf("[%8.3f] cairn-hil: %s\n", t, line.c_str());
    for (const hil::RobotContacts& c : fleet.new_contacts()) {
      std::printf("[%8.3f] cairn-hil: contact: robot %d and robot %d touch (contact %llu between them)\n", t, c.a, c.b,
                  static_cast<unsigned long long>(c.contacts));
      if (truth) std::fprintf(truth.get(), "# contact %.3f %d %d\n", t, c.a, c.b);
    }
    if (truth) fleet.write_truth(truth.get(), t);
    if (now >= next_report) {
      next_report += seconds_to_nanos(o.report_period);
      for (std::size_t i = 0; i < fleet.size(); ++i) {
        const hil::TruthSample s = fleet.bench(i).truth();
        std::printf("[%8.3f] cairn-hil: robot %d at %.2f %.2f %.0f deg, travelled %.1f m\n", t, fleet.id(i), s.pose.x,
                    s.pose.y, s.pose.theta * 57.29578, s.odometer);
      }
    }
    std::fflush(stdout);
    next += 100 * kNanosPerMilli;
    sleep_while_running(next);
  }
  const double t = nanos_to_seconds(clock.now() - start);
  if (truth) fleet.write_truth(truth.get(), t);
  for (std::size_t i = 0; i < fleet.size(); ++i) {
    const hil::TruthSample s = fleet.bench(i).truth();
    std::printf("cairn-hil: final robot %d at %.3f %.3f %.4f rad, travelled %.2f m", fleet.id(i), s.pose.x, s.pose.y,
                s.pose.theta, s.odometer);
    if (o.shared_world) {
      std::printf(", blocked %llu step(s) by obstacles and %llu by robots", static_cast<unsigned long long>(s.wall_bumps),
                  static_cast<unsigned long long>(s.robot_contacts));
    }
    std::printf("\n");
  }
  if (o.shared_world) {
    const auto contacts = fleet.contacts();
    std::printf("cairn-hil: %zu pair(s) of robots touched\n", contacts.size());
    for (const hil::RobotContacts& c : contacts) {
      std::printf("cairn-hil: contacts robot %d and robot %d: %llu (%llu step(s) refused)\n", c.a, c.b,
                  static_cast<unsigned long long>(c.contacts), static_cast<unsigned long long>(c.refused_moves));
      if (truth) std::fprintf(truth.get(), "# contacts %d %d %llu\n", c.a, c.b, static_cast<unsigned long long>(c.contacts));
    }
  }
  std::fflush(stdout);
  fleet.stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-hil: hardware-in-the-loop bench: device emulators that speak the devices' real wire protocols"};
  app.require_subcommand(1);
  std::string world_path = "hil/worlds/office.world", pose_text = "2,10,0";
  int tcp_port = -1;
  double noise = 0.005, boot = 0.3;
  auto* lms = app.add_subcommand("lms", "serve an emulated SICK LMS2xx (prints the URI to connect to)");
  lms->add_option("--world", world_path, "world file")->check(CLI::ExistingFile);
  lms->add_option("--pose", pose_text, "sensor pose in the world: x,y,theta (m, m, rad)");
  lms->add_option("--tcp", tcp_port, "serve on 127.0.0.1:PORT (0 = any free port) instead of a pty");
  lms->add_option("--noise", noise, "range noise sigma (m)");
  lms->add_option("--boot", boot, "seconds from power-on to the power-on telegram");

  RobotsOptions ro;
  auto* robots = app.add_subcommand(
      "robots", "serve whole robots (LMS2xx on a pty, two CiA 402 drives on a user-space CAN bus, a Modbus TCP power\n"
                "board, body physics) in a world; writes a cairn-robot configuration per robot");
  robots->add_option("--world", ro.world, "world file (robots start at its 'start' lines and follow its 'route' lines)")
      ->check(CLI::ExistingFile)->capture_default_str();
  robots->add_option("--count", ro.count, "robots 1..N")->check(CLI::Range(1, 32))->capture_default_str();
  robots->add_option("--ids", ro.ids, "robot ids instead of --count (e.g. --ids 2 5)");
  robots->add_option("--template", ro.robot_template, "robot configuration template (its [robot], [devices] and [motion] waypoints are filled in)")
      ->check(CLI::ExistingFile)->capture_default_str();
  robots->add_option("--out", ro.out_dir, "directory for the written robot-<id>.toml files")->capture_default_str();
  robots->add_option("--truth", ro.truth_path, "write ground truth at 10 Hz to this file: t_s robot x y theta odometer_m");
  robots->add_option("--fault", ro.faults, "schedule a device fault T:ROBOT:KIND[:DURATION] (kinds estop, laser, drive, power); repeatable");
  robots->add_option("--duration", ro.duration, "stop after this many seconds (0 = until SIGINT/SIGTERM)");
  robots->add_option("--report", ro.report_period, "seconds between ground-truth progress lines")->capture_default_str();
  robots->add_flag("--lms-tcp", ro.lms_tcp, "serve the lasers on 127.0.0.1 TCP ports instead of ptys");
  robots->add_flag("--shared-world", ro.shared_world,
                   "one world for all robots: each laser sees the other robots' bodies and a body stops at another "
                   "(contacts are logged and counted)");
  // The VM bench's real devices (scripts/vm-bench.sh): one robot.
  robots->add_option("--can-iface", ro.can_iface, "the drives on this SocketCAN interface (e.g. vcan0) instead of a user-space bus; one robot");
  auto* uart = robots->add_option("--lms-uart", ro.lms_uart, "serve the laser on this serial port (e.g. /dev/ttyS2); one robot");
  auto* host = robots->add_option("--lms-host-uri", ro.lms_host_uri, "what the robot opens, the other end of the cable (e.g. serial:/dev/ttyS1)");
  auto* baud = robots->add_option("--lms-baud", ro.lms_uart_baud, "the laser's line rate on its UART")
                   ->check(CLI::IsMember({9600, 19200, 38400}))->capture_default_str();
  uart->needs(host);
  host->needs(uart);
  baud->needs(uart);
  uart->excludes("--lms-tcp");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-hil", [&] {
    if (*robots) return run_robots(ro);
    return run_lms(world_path, pose_text, tcp_port, noise, boot);
  });
}
