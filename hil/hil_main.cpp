// cairn-hil: the hardware-in-the-loop bench. Today: `cairn-hil lms` serves an emulated
// SICK LMS2xx over a pty or TCP, scanning a world from a fixed pose, until interrupted.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <sstream>

#include "common/program.hpp"
#include "hil/lms2xx/lms_server.hpp"

using namespace cairn;

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
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-hil", [&] {
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
    auto& clock = MonotonicClock::instance();
    while (!shutdown_requested()) clock.sleep_until(clock.now() + 50 * kNanosPerMilli);
    server.with_device([](hil::LmsDevice& d) {
      const auto& c = d.counters();
      std::printf("cairn-hil: %llu requests, %llu scans sent, %llu dropped (line busy), %llu baud changes\n",
                  static_cast<unsigned long long>(c.requests), static_cast<unsigned long long>(c.scans_sent),
                  static_cast<unsigned long long>(c.scans_dropped_busy), static_cast<unsigned long long>(c.baud_changes));
      return 0;
    });
    server.stop();
    return 0;
  });
}
