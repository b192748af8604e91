// cairn-test-feeder: publishes a deterministic fleet stream (tools/fleet_stream/fleet_scenario.hpp)
// over DDS, as robots would: OdometryIncrement and FeatureObservations, reliable and
// transient-local with a deep history, then keeps the history available until killed.
#include <CLI/CLI.hpp>
#include <cstdio>
#include "common/program.hpp"
#include "tools/fleet_stream/fleet_publisher.hpp"

using namespace cairn;

int main(int argc, char** argv) {
  CLI::App app{"cairn-test-feeder: publishes a simulated fleet's odometry and features (test support)"};
  int robots = 3, steps = 300, domain = 0, depth = 2048, readers = 0;
  double rate = 100;
  app.add_option("--robots", robots);
  app.add_option("--steps", steps);
  app.add_option("--domain", domain);
  app.add_option("--rate", rate, "odometry steps per second (all robots)");
  app.add_option("--depth", depth, "history depth per robot");
  app.add_option("--readers", readers, "before publishing, wait up to 10 s for this many readers of each topic (a reader "
                 "that matches mid-stream was seen to miss a robot's first sample)");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  const fleet_stream::FleetScenario s = fleet_stream::make_fleet_scenario(robots, steps);
  dds::Participant pp(dds::loopback_profile(static_cast<std::uint32_t>(domain)));
  fleet_stream::FleetPublisher fleet(pp, robots, depth);
  if (readers > 0 && !fleet.wait_for_readers(static_cast<std::uint32_t>(readers), 10 * kNanosPerSecond)) {
    std::fprintf(stderr, "feeder: fewer than %d readers after 10 s\n", readers);
    return 1;
  }
  auto& clock = MonotonicClock::instance();
  Nanos next = clock.now();
  const Nanos period = static_cast<Nanos>(1e9 / rate);
  for (const auto& m : s.messages) {
    if (shutdown_requested()) break;
    const msg::OdometryIncrement* o = fleet.publish(m);
    if (o && o->robot_id == robots) {  // one simulated step done
      next += period;
      clock.sleep_until(next);
    }
    if ((fleet.odometry() + fleet.features()) % 500 == 0) {
      std::printf("feeder: %llu odometry, %llu features sent\n", static_cast<unsigned long long>(fleet.odometry()),
                  static_cast<unsigned long long>(fleet.features()));
      std::fflush(stdout);
    }
  }
  std::printf("feeder: done: %llu odometry, %llu features\n", static_cast<unsigned long long>(fleet.odometry()),
              static_cast<unsigned long long>(fleet.features()));
  std::fflush(stdout);
  while (!shutdown_requested()) clock.sleep_until(clock.now() + 50 * kNanosPerMilli);
  return 0;
}
