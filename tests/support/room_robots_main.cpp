// cairn-test-room-robots: fake robots for the web view's browser test. Robots 1 and 2
// drive circles of 1 m in a walled 8 m x 6 m room ([-4, 4] x [-3, 3] m, global frame),
// publishing what cairn-robot publishes to the base: RobotStatus (5 Hz, with RT loop
// figures), exact odometry (20 Hz) and 360-beam scans ray-cast against the walls (5 Hz).
// The walls are where the test looks for them on the page's canvas. Robot 1 bids for one
// frontier (1 Hz); robot 2 starts latched ("reset required"), standing still, until a
// SafetyReset for it arrives (as cairn-robot's bridge takes it; printed); a SafetyStop for
// it or for every robot (id 0) latches it again. Runs until SIGINT/SIGTERM or --duration.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>

#include "common/dds/convert.hpp"
#include "common/dds/qos.hpp"
#include "common/dds/topics.hpp"
#include "common/program.hpp"

using namespace cairn;

namespace {

constexpr double kHalfW = 4.0, kHalfH = 3.0;  // the room's walls: x = ±4, y = ±3 (m)
constexpr int kRobots = 2;
// Global start poses: they must match the base configuration's initial_pose (tests/web/base-web.toml).
const Pose2 kStarts[kRobots] = {{-1.5, 0.0, 0.0}, {1.5, 0.0, std::numbers::pi}};

// Distance from p along heading a to the room's walls (it is inside the room).
double wall_range(const Vec2& p, double a) {
  const double c = std::cos(a), s = std::sin(a);
  double t = 1e9;
  if (c > 1e-9) t = std::min(t, (kHalfW - p.x()) / c);
  if (c < -1e-9) t = std::min(t, (-kHalfW - p.x()) / c);
  if (s > 1e-9) t = std::min(t, (kHalfH - p.y()) / s);
  if (s < -1e-9) t = std::min(t, (-kHalfH - p.y()) / s);
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-test-room-robots: two fake robots in a walled room, over DDS (test support)"};
  int domain = 0;
  double duration_s = 60;
  app.add_option("--domain", domain)->required();
  app.add_option("--duration", duration_s, "stop after this many seconds (a test that dies leaves no robots behind)");
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  dds::Participant pp(dds::loopback_profile(static_cast<std::uint32_t>(domain)));
  dds::Topic<cairn_RobotStatus> status_topic(pp);
  dds::Topic<cairn_OdometryIncrement> odom_topic(pp);
  dds::Topic<cairn_LaserScan> scan_topic(pp);
  // Each robot writes in its own partition, as cairn-robot does: one writer per robot.
  dds::Writer<cairn_RobotStatus> status[kRobots] = {{pp, status_topic, dds::state_qos(1), 1},
                                                    {pp, status_topic, dds::state_qos(1), 2}};
  dds::Writer<cairn_OdometryIncrement> odom[kRobots] = {{pp, odom_topic, dds::latched_qos(64), 1},
                                                        {pp, odom_topic, dds::latched_qos(64), 2}};
  dds::Writer<cairn_LaserScan> scans[kRobots] = {{pp, scan_topic, dds::state_qos(4), 1},
                                                 {pp, scan_topic, dds::state_qos(4), 2}};
  dds::Topic<cairn_Bid> bid_topic(pp);
  dds::Writer<cairn_Bid> bids(pp, bid_topic, dds::state_qos(1), 1);  // robot 1 bids
  dds::Topic<cairn_SafetyReset> reset_topic(pp);
  dds::Reader<cairn_SafetyReset> resets(pp, reset_topic, dds::state_qos(4));
  dds::Topic<cairn_SafetyStop> stop_topic(pp);
  dds::Reader<cairn_SafetyStop> stops(pp, stop_topic, dds::state_qos(4));
  bool latched[kRobots] = {false, true};
  auto scan_sample = std::make_unique<cairn_LaserScan>();

  auto& clock = MonotonicClock::instance();
  const Nanos period = 50 * kNanosPerMilli, t_start = clock.now();
  Pose2 local[kRobots];  // each robot's pose in its local frame (its start), exact
  std::uint32_t seq = 0;
  Nanos next = t_start;
  const Nanos t_end = t_start + seconds_to_nanos(duration_s);
  while (!shutdown_requested() && clock.now() < t_end) {
    next += period;
    clock.sleep_until(next);
    const Nanos t1 = clock.now();
    ++seq;
    stops.take([&](const cairn_SafetyStop& m, const dds_sample_info_t&) {
      for (int r = 0; r < kRobots; ++r) {
        if (m.robot_id != 0 && m.robot_id != r + 1) continue;
        latched[r] = true;
        std::printf("robot %d: remote e-stop by '%s'\n", r + 1, m.issued_by);
      }
      std::fflush(stdout);
    });
    resets.take([&](const cairn_SafetyReset& m, const dds_sample_info_t&) {
      if (m.robot_id < 1 || m.robot_id > kRobots || !latched[m.robot_id - 1]) return;
      latched[m.robot_id - 1] = false;
      std::printf("robot %d: reset by '%s'\n", m.robot_id, m.issued_by);
      std::fflush(stdout);
    });
    if (seq % 20 == 0) {  // robot 1's bid: one frontier in the room's upper right, with its region
      msg::Bid b;
      b.robot_id = 1;
      b.seq = seq / 20;
      b.n_items = 1;
      b.items[0] = {2.5, 1.5, 150.0, 4.0, 2.0, 1.0, 3.5, 2.5};
      cairn_Bid bd{};
      dds::to_dds(b, &bd);
      bids.write(bd);
    }
    for (int r = 0; r < kRobots; ++r) {
      const auto id = static_cast<std::uint16_t>(r + 1);
      const Pose2 step = latched[r] ? Pose2{0, 0, 0} : Pose2{0.3 * 0.05, 0.0, 0.3 * 0.05};  // 0.3 m/s on a 1 m circle
      local[r] = compose(local[r], step);
      msg::OdometryIncrement o;
      o.robot_id = id;
      o.seq = seq;
      o.t0 = t1 - period;
      o.t1 = t1;
      o.delta = step;
      o.delta_cov = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-7};
      o.local_pose = local[r];
      o.boot_epoch = 7;
      cairn_OdometryIncrement od{};
      dds::to_dds(o, &od);
      odom[r].write(od);
      if (seq % 4 != 0) continue;  // status and scans at 5 Hz
      cairn_RobotStatus st{};
      st.robot_id = id;
      st.seq = seq / 4;
      st.stamp_ns = t1;
      dds::set_text(st.name, r == 0 ? "rover-a" : "rover-b");
      st.mode = cairn_MODE_RUNNING;
      st.stop_reason = latched[r] ? 8 : 0;  // 8: reset required (common/stop_reason.hpp)
      dds::set_text(st.stop_text, latched[r] ? "e-stop released; reset required" : "");
      st.loop_period_mean_us = 10000.0f;
      st.loop_period_p99_us = 10100.0f;
      st.loop_jitter_max_us = 150.0f;
      st.loop_cycles = seq * 5;
      st.local_pose.x = local[r].x;
      st.local_pose.y = local[r].y;
      st.local_pose.theta = local[r].theta;
      st.battery_voltage = 25.2f;
      st.battery_soc = 0.8f;
      st.n_devices = 1;
      dds::set_text(st.devices[0].name, "lms");
      dds::set_text(st.devices[0].reason, "scanning");
      status[r].write(st);
      const Pose2 world = compose(kStarts[r], local[r]);
      msg::LaserScan s;
      s.robot_id = id;
      s.seq = seq / 4;
      s.stamp = t1;
      s.n_beams = 360;
      s.angle_min = static_cast<float>(-std::numbers::pi);
      s.angle_increment = static_cast<float>(std::numbers::pi / 180);
      for (std::size_t b = 0; b < s.n_beams; ++b) {
        const double a = world.theta - std::numbers::pi + static_cast<double>(b) * std::numbers::pi / 180;
        s.ranges_mm[b] = static_cast<std::uint16_t>(std::lround(wall_range(Vec2(world.x, world.y), a) * 1000));
      }
      s.pose = local[r];
      *scan_sample = {};
      dds::to_dds(s, scan_sample.get());
      scans[r].write(*scan_sample);
    }
  }
  return 0;
}
