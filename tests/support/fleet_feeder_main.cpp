// cairn-test-feeder: publishes a deterministic fleet stream (tools/fleet_stream/fleet_scenario.hpp)
// over DDS, as robots would: OdometryIncrement and FeatureObservations, reliable and
// transient-local with a deep history, then keeps the history available until killed.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "common/dds/topics.hpp"
#include "common/program.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"

using namespace cairn;

int main(int argc, char** argv) {
  CLI::App app{"cairn-test-feeder: publishes a simulated fleet's odometry and features (test support)"};
  int robots = 3, steps = 300, domain = 0, depth = 2048;
  double rate = 100;
  app.add_option("--robots", robots);
  app.add_option("--steps", steps);
  app.add_option("--domain", domain);
  app.add_option("--rate", rate, "odometry steps per second (all robots)");
  app.add_option("--depth", depth, "history depth per robot");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  const fleet_stream::FleetScenario s = fleet_stream::make_fleet_scenario(robots, steps);
  dds::Participant pp(dds::loopback_profile(static_cast<std::uint32_t>(domain)));
  dds::Topic<cairn_OdometryIncrement> ot(pp);
  dds::Topic<cairn_FeatureObservations> ft(pp);
  dds::Writer<cairn_OdometryIncrement> ow(pp, ot, dds::latched_qos(depth));
  dds::Writer<cairn_FeatureObservations> fw(pp, ft, dds::latched_qos(depth));
  std::size_t n_odo = 0, n_feat = 0;
  auto& clock = MonotonicClock::instance();
  Nanos next = clock.now();
  const Nanos period = static_cast<Nanos>(1e9 / rate);
  auto feat = std::make_unique<cairn_FeatureObservations>();
  for (const auto& m : s.messages) {
    if (shutdown_requested()) break;
    if (const auto* o = std::get_if<msg::OdometryIncrement>(&m)) {
      cairn_OdometryIncrement out{};
      dds::to_dds(*o, &out);
      ow.write(out);
      ++n_odo;
      if (o->robot_id == robots) {  // one simulated step done
        next += period;
        clock.sleep_until(next);
      }
    } else {
      *feat = {};
      dds::to_dds(std::get<msg::FeatureObservations>(m), feat.get());
      fw.write(*feat);
      ++n_feat;
    }
    if ((n_odo + n_feat) % 500 == 0) {
      std::printf("feeder: %zu odometry, %zu features sent\n", n_odo, n_feat);
      std::fflush(stdout);
    }
  }
  std::printf("feeder: done: %zu odometry, %zu features\n", n_odo, n_feat);
  std::fflush(stdout);
  while (!shutdown_requested()) clock.sleep_until(clock.now() + 50 * kNanosPerMilli);
  return 0;
}
