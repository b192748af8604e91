// The CANopen master's logic on simulated time: the production DriveMaster against two
// emulated CiA 402 drives on a simulated bus (hil/cia402/sim_drive_bus). No threads, no
// sleeps: every bound is asserted to the bus analyser's timestamps, without scheduling
// slack. The same master over the user-space CAN hub, in real time, is canopen_drive_test
// (the transport); this file is the logic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "drivers/canopen/canopen_codec.hpp"
#include "drivers/canopen/diff_drive.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "drivers/canopen/object_dictionary.hpp"
#include "drivers/canopen/pdo_map.hpp"
#include "hil/cia402/sim_drive_bus.hpp"
#include "hil/robot/diff_robot.hpp"

namespace cairn {
namespace {

using canopen::NodePhase;

struct SimBench {
  explicit SimBench(bool halt_quirk = false)
      : bus(&clock, drives(halt_quirk)), master(&bus, &clock, mc) {}

  static std::vector<hil::DriveConfig> drives(bool halt_quirk) {
    std::vector<hil::DriveConfig> d(2);
    d[0].node = 1;
    d[1].node = 2;
    d[1].reject_halt = halt_quirk;
    return d;
  }
  /// Steps the master until pred() holds; simulated seconds it took, or -1 after timeout_s.
  template <typename P>
  double until(P pred, double timeout_s) {
    const Nanos t0 = clock.now(), end = t0 + seconds_to_nanos(timeout_s);
    while (clock.now() < end) {
      if (pred()) return nanos_to_seconds(clock.now() - t0);
      master.step();
    }
    return pred() ? nanos_to_seconds(clock.now() - t0) : -1;
  }
  void run_for(double seconds) {
    const Nanos end = clock.now() + seconds_to_nanos(seconds);
    while (clock.now() < end) master.step();
  }
  bool enabled() const { return master.all_enabled(); }
  std::string events() const {
    std::string s;
    for (std::size_t i = 0; i < master.event_count(); ++i) {
      const auto& e = master.event(i);
      s += std::to_string(nanos_to_seconds(e.time)) + " s: node " + std::to_string(e.node) + " -> " +
           canopen::phase_name(e.to) + ": " + e.reason.data() + "\n";
    }
    return s;
  }
  Nanos event_time(std::uint8_t node, NodePhase to) const {
    Nanos at = -1;
    for (std::size_t i = 0; i < master.event_count(); ++i) {
      if (master.event(i).node == node && master.event(i).to == to) at = master.event(i).time;
    }
    return at;
  }
  /// The last frame on the bus with this COB-ID at or before `t` (-1: none).
  Nanos last_frame(std::uint32_t id, Nanos t) const {
    Nanos at = -1;
    for (const auto& e : bus.log()) {
      if (e.time <= t && e.frame.id == id) at = e.time;
    }
    return at;
  }
  /// The first frame on the bus after `t` matching pred (-1: none).
  template <typename P>
  Nanos first_frame_after(Nanos t, P pred) const {
    for (const auto& e : bus.log()) {
      if (e.time >= t && pred(e)) return e.time;
    }
    return -1;
  }

  SimClock clock{kNanosPerSecond};
  const canopen::MasterConfig mc{};  // the shipped defaults
  hil::SimDriveBus bus;
  canopen::DriveMaster master;
};

bool zero_rpdo_to(const hil::BusLogEntry& e, std::uint8_t node) {
  const can::Frame& f = e.frame;
  return e.from_master && f.id == 0x200u + node && f.len >= 6 && f.data[2] == 0 && f.data[3] == 0 && f.data[4] == 0 &&
         f.data[5] == 0;
}

TEST(CanopenSim, BootUpToOperationEnabledAndFeedbackAtTheSyncRate) {
  SimBench b(/*halt_quirk=*/true);  // drive 2 faults on HALT: the master must never send it
  const double t = b.until([&] { return b.enabled(); }, 5.0);
  ASSERT_GT(t, 0) << b.events();
  // The drives boot in 0.1 s; configuration is a few SDO round trips per drive.
  EXPECT_LT(t, 0.5) << b.events();
  std::printf("boot-up to operation enabled (both drives, simulated): %.3f s\n", t);
  const std::int32_t cmd[] = {50000, -30000};
  b.master.command(cmd);
  const auto updates0 = b.master.feedback(0).updates;
  b.run_for(1.0);
  // One TPDO per SYNC (10 ms): exactly 100 in a simulated second, +-1 for the phase.
  EXPECT_NEAR(static_cast<double>(b.master.feedback(0).updates - updates0), 100.0, 1.0);
  EXPECT_NEAR(b.bus.drive(0).velocity(), 50000, 1);
  EXPECT_NEAR(b.bus.drive(1).velocity(), -30000, 1);
  EXPECT_NEAR(b.master.feedback(0).velocity, 50000, 1);
  EXPECT_GT(b.master.feedback(0).position, 45000);  // ~1 s at 50000/s after the ramp
  EXPECT_EQ(b.master.drive_state(1), cia402::State::kOperationEnabled);
  EXPECT_EQ(b.bus.drive(1).state(), cia402::State::kOperationEnabled) << "drive 2 faulted: the master sent HALT";
}

// Heartbeat consumer (shipped defaults: producer 50 ms, consumer 110 ms): drive 2 falls
// silent; "lost" is declared in [110, 110 + io_slice] ms after its last heartbeat on the
// bus, and the zero RPDO reaches drive 1 by 110 ms + one SYNC cycle. Exact on simulated time.
TEST(CanopenSim, HeartbeatLossZeroesEveryDriveWithinTimeoutPlusOneCycle) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  const std::int32_t cmd[] = {40000, 40000};
  b.master.command(cmd);
  b.run_for(0.237);  // an arbitrary phase against the heartbeat period
  const Nanos silent_at = b.clock.now();
  b.bus.drive(1).set_silent(true);
  ASSERT_GT(b.until([&] { return b.event_time(2, NodePhase::kLost) > 0 && b.bus.drive(0).target_velocity() == 0; }, 1.0), 0)
      << b.events();
  const Nanos last_hb = b.last_frame(0x702, silent_at);
  ASSERT_GT(last_hb, 0);
  const Nanos lost = b.event_time(2, NodePhase::kLost);
  const Nanos zero = b.first_frame_after(silent_at, [](const hil::BusLogEntry& e) { return zero_rpdo_to(e, 1); });
  ASSERT_GT(zero, 0);
  const double lost_ms = nanos_to_seconds(lost - last_hb) * 1e3, zero_ms = nanos_to_seconds(zero - last_hb) * 1e3;
  std::printf("after drive 2's last heartbeat: lost at %.2f ms, zero RPDO to drive 1 at %.2f ms\n", lost_ms, zero_ms);
  const double timeout_ms = nanos_to_seconds(b.mc.heartbeat_timeout) * 1e3;
  EXPECT_GE(lost_ms, timeout_ms) << "declared lost before the consumer timeout";
  EXPECT_LE(lost_ms, timeout_ms + nanos_to_seconds(b.mc.io_slice) * 1e3) << b.events();
  EXPECT_LE(zero_ms, timeout_ms + nanos_to_seconds(b.mc.sync_period) * 1e3) << b.events();
  EXPECT_EQ(b.master.commanded(0), 0);
  // It comes back: reset, reconfigured, enabled again.
  b.bus.drive(1).set_silent(false);
  EXPECT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
}

TEST(CanopenSim, OverCurrentFaultIsResetAndTheDriveReEnabled) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  const std::int32_t cmd[] = {20000, 20000};
  b.master.command(cmd);
  b.run_for(0.1);
  b.bus.drive(0).over_current(b.clock.now());
  // The EMCY arrives with the fault; the other drive's zero goes out with the next SYNC cycle.
  const double off = b.until([&] { return !b.enabled() && b.master.commanded(1) == 0; }, 0.5);
  ASSERT_GE(off, 0) << b.events();
  EXPECT_LE(off, nanos_to_seconds(b.mc.sync_period)) << b.events();
  const double t = b.until([&] { return b.enabled(); }, 3.0);
  ASSERT_GT(t, 0) << b.events();
  std::printf("over-current fault -> enabled again after %.3f s (simulated)\n", t);
  EXPECT_EQ(b.master.last_emcy(0), 0x0000);  // the reset EMCY
  EXPECT_NE(b.events().find("EMCY 0x2310: output current (over-current)"), std::string::npos) << b.events();
}

TEST(CanopenSim, BusOffStopsTheDrivesAndIsRecoveredOnlyAfterTheFaultClears) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  const std::int32_t cmd[] = {30000, 30000};
  b.master.command(cmd);
  ASSERT_GT(b.until([&] { return b.bus.drive(0).velocity() > 29000; }, 1.0), 0);
  const Nanos fault = b.clock.now();
  b.bus.inject_bus_off(500 * kNanosPerMilli);
  // Nothing reaches the drives: each declares SYNC loss 0.1 s (sync_loss_s) after the last
  // SYNC it heard (at most one cycle before the fault) and ramps down at its profile
  // deceleration (0x6084: 400000/s, so 75 ms from 30000/s).
  const double tick = 1e-4;
  const double lost = b.until([&] { return b.bus.drive(0).sync_lost() && b.bus.drive(1).sync_lost(); }, 1.0);
  ASSERT_GE(lost, 0) << b.events();
  EXPECT_LE(lost, 0.1 + 0.010 + tick);
  const double stopped = lost + b.until([&] { return b.bus.drive(0).velocity() == 0.0 && b.bus.drive(1).velocity() == 0.0; }, 1.0);
  EXPECT_LE(stopped, 0.1 + 0.010 + 30000.0 / 400000.0 + 2 * tick);
  EXPECT_FALSE(b.enabled());
  EXPECT_EQ(b.first_frame_after(fault + 1, [](const hil::BusLogEntry& e) { return e.from_master; }),
            b.first_frame_after(fault + 500 * kNanosPerMilli, [](const hil::BusLogEntry& e) { return e.from_master; }))
      << "the master sent while its controller was bus-off";
  const double t = b.until([&] { return b.enabled(); }, 5.0);
  ASSERT_GT(t, 0) << b.events();
  std::printf("bus-off held 500 ms: drives stopped after %.0f ms; enabled again %.3f s later (simulated)\n", stopped * 1000, t);
  EXPECT_GE(nanos_to_seconds(b.clock.now() - fault), 0.5);  // not before the fault cleared
  EXPECT_GE(b.bus.stats().bus_off, 1u);
  EXPECT_GE(b.bus.stats().restarts, 1u);
}

TEST(CanopenSim, DisableAllReachesBothDrivesAtOnce) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  b.master.disable_all("e-stop pressed");
  // disable_all sends the controlwords itself: no simulated time passes before both
  // drives leave operation enabled.
  EXPECT_NE(b.bus.drive(0).state(), cia402::State::kOperationEnabled);
  EXPECT_NE(b.bus.drive(1).state(), cia402::State::kOperationEnabled);
  EXPECT_EQ(b.master.commanded(0), 0);
  EXPECT_EQ(b.master.commanded(1), 0);
}

TEST(CanopenSim, GarbageFramesAreSurvived) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  for (std::size_t i = 0; i < b.bus.drives(); ++i) b.bus.drive(i).inject_garbage(300, 7 + i);
  b.run_for(0.3);
  EXPECT_TRUE(b.enabled()) << b.events();
  EXPECT_EQ(cia402::decode(b.master.feedback(0).statusword), cia402::State::kOperationEnabled);
}

// The drives' wheels move a simulated robot: after every master step the robot is advanced
// by the step's simulated time at the drives' velocities (as the HIL bench does).
TEST(CanopenSim, TwoDrivesMoveASimulatedRobotInTheWorld) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  hil::World world = hil::World::parse("box 0 0 20 20\n", "hall");
  canopen::DiffDriveGeometry g;
  hil::DiffRobot robot(1, g, {5, 5, 0}, 0.3, &world);
  // Drives at (v, w) until `done` holds or `timeout` simulated s pass. Returns the drives'
  // velocities at the end, which must equal the command once the ramp is over.
  struct Wheels {
    double left, right;
    double max_step_s;  // the longest master step: how far past the target the loop can end
  };
  auto drive_until = [&](double v, double w, auto done, double timeout) {
    const canopen::WheelCommand c = canopen::wheel_command(g, v, w);
    const std::int32_t cmd[] = {c.left, c.right};
    b.master.command(cmd);
    const Nanos end = b.clock.now() + seconds_to_nanos(timeout);
    Nanos last = b.clock.now();
    Wheels wheels{0, 0, 0};
    while (!done() && b.clock.now() < end) {
      b.master.step();
      const Nanos now = b.clock.now();
      wheels.left = b.bus.drive(0).velocity();
      wheels.right = b.bus.drive(1).velocity();
      robot.step(wheels.left, wheels.right, nanos_to_seconds(now - last));
      wheels.max_step_s = std::max(wheels.max_step_s, nanos_to_seconds(now - last));
      last = now;
    }
    EXPECT_TRUE(done()) << "not reached in " << timeout << " s; pose (" << robot.pose().x << ", " << robot.pose().y << ", "
                        << robot.pose().theta << ")";
    EXPECT_NEAR(wheels.left, c.left, 0.02 * std::abs(c.left) + 1) << "left drive's steady velocity";
    EXPECT_NEAR(wheels.right, c.right, 0.02 * std::abs(c.right) + 1) << "right drive's steady velocity";
    return wheels;
  };
  // The loop stops at the first step past the target: at most one step (0.5 m/s or rad/s) over.
  const Wheels straight = drive_until(0.5, 0.0, [&] { return robot.pose().x >= 6.0; }, 5.0);  // 1 m straight ahead
  EXPECT_LE(robot.pose().x, 6.0 + 0.5 * straight.max_step_s + 1e-3);
  EXPECT_NEAR(robot.pose().y, 5.0, 0.01);  // straight: equal wheels
  EXPECT_NEAR(robot.pose().theta, 0.0, 0.01);
  // Turning on the spot, the robot moves only until the new command reaches the drives (the
  // next SYNC's RPDO: one cycle; on simulated time no allowance for load, the wall-clock
  // bench allowed 100 ms) and while its wheels ramp down from 0.5 m/s at the profile
  // acceleration (0x6083 = 400 000 increments/s²): v²/2a = 4.1 cm.
  const double a = 400000.0 * g.wheel_radius_m / g.counts_per_wheel_rad();
  const double ramp_m = 0.5 * 0.5 / (2 * a) + 0.5 * nanos_to_seconds(b.mc.sync_period);
  const Pose2 before_turn = robot.pose();
  const Wheels turn = drive_until(0.0, 0.5, [&] { return robot.pose().theta >= 1.0; }, 5.0);
  EXPECT_LE(robot.pose().theta, 1.0 + 0.5 * turn.max_step_s + 1e-3);
  EXPECT_LT(std::hypot(robot.pose().x - before_turn.x, robot.pose().y - before_turn.y), ramp_m + 0.01);
  auto wheel_speed = [&](std::size_t k) { return b.bus.drive(k).velocity(); };
  drive_until(0.0, 0.0, [&] { return wheel_speed(0) == 0.0 && wheel_speed(1) == 0.0; }, 1.0);
  std::printf("robot after 1 m straight and a 1 rad turn (simulated): (%.3f, %.3f, %.3f)\n", robot.pose().x, robot.pose().y,
              robot.pose().theta);
}

// The master's SDO configuration of node 1 on the wire, write by write (generated from
// pdo_map::kDrive; the literals are the CiA 301 / 402 values it must produce), each one
// acknowledged by the drive.
TEST(CanopenSim, TheConfigurationSequenceOnTheWire) {
  SimBench b;
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  struct Write {
    std::uint16_t index;
    std::uint8_t sub;
    std::uint32_t value;
    std::uint8_t size;
    bool operator==(const Write&) const = default;
  };
  std::vector<Write> writes;
  std::size_t acks = 0, other_responses = 0;
  for (const auto& e : b.bus.log()) {
    const can::Frame& f = e.frame;
    if (e.from_master && f.id == 0x601 && (f.data[0] >> 5) == 1) {
      ASSERT_EQ(f.data[0] & 0x03, 0x03) << "expedited, size indicated";
      const auto size = static_cast<std::uint8_t>(4 - ((f.data[0] >> 2) & 3));
      std::uint32_t v = 0;
      for (int i = 0; i < size; ++i) v |= static_cast<std::uint32_t>(f.data[4 + i]) << (8 * i);
      writes.push_back({static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8)), f.data[3], v, size});
    } else if (!e.from_master && f.id == 0x581) {
      (canopen::decode_sdo_response(f).type == canopen::SdoResponse::Type::kDownloadAck ? acks : other_responses)++;
    }
  }
  const std::vector<Write> expected = {
      {0x1017, 0, 50, 2},           {0x6060, 0, 9, 1},  // heartbeat 50 ms, cyclic synchronous velocity
      // RPDO1: disable, clear, controlword u16, target velocity i32, count, every SYNC, enable
      {0x1400, 1, 0x80000201, 4},   {0x1600, 0, 0, 1},  {0x1600, 1, 0x60400010, 4}, {0x1600, 2, 0x60FF0020, 4},
      {0x1600, 0, 2, 1},            {0x1400, 2, 1, 1},  {0x1400, 1, 0x201, 4},
      // TPDO1: statusword u16, velocity actual i32
      {0x1800, 1, 0x80000181, 4},   {0x1A00, 0, 0, 1},  {0x1A00, 1, 0x60410010, 4}, {0x1A00, 2, 0x606C0020, 4},
      {0x1A00, 0, 2, 1},            {0x1800, 2, 1, 1},  {0x1800, 1, 0x181, 4},
      // TPDO2: position actual i32
      {0x1801, 1, 0x80000281, 4},   {0x1A01, 0, 0, 1},  {0x1A01, 1, 0x60640020, 4}, {0x1A01, 0, 1, 1},
      {0x1801, 2, 1, 1},            {0x1801, 1, 0x281, 4},
  };
  ASSERT_EQ(writes.size(), expected.size());
  for (std::size_t i = 0; i < writes.size(); ++i) {
    EXPECT_EQ(writes[i], expected[i]) << "write " << i << ": 0x" << std::hex << writes[i].index << " sub " << int{writes[i].sub}
                                      << " = 0x" << writes[i].value;
  }
  EXPECT_EQ(acks, expected.size());
  EXPECT_EQ(other_responses, 0u);
}

// One PDO table on both sides. Drives whose mapping is something else (disabled PDOs,
// other objects, another transmission type) are remapped by the master's configuration to
// exactly pdo_map::kDrive, read back from their object dictionaries; then the master's
// RPDOs, packed from the table, are applied by the drives, unpacking by their own mapping,
// and the drives' TPDOs decode through the master's table to the drives' values, negative
// ones included.
TEST(CanopenSim, TheMasterWritesThePdoTableAndBothSidesAgreeOnTheValues) {
  using namespace canopen;
  SimBench b;
  // The emulated drive's factory mapping is the table's too (but for the RPDO's type: it
  // applies RPDOs on arrival, event-driven).
  auto expect_table_mapping = [](const hil::DriveNode& d, std::uint8_t node, bool factory) {
    for (const PdoMapping& m : pdo_map::kDrive) {
      const std::uint16_t comm = communication_index(m), map = mapping_index(m);
      const std::uint32_t type = factory && m.direction == PdoDirection::kRpdo ? od::kTransmissionEventDriven : m.transmission_type;
      EXPECT_EQ(d.od(comm, od::kPdoCobId), cob_id(m, node)) << "node " << int{node} << std::hex << " 0x" << comm;
      EXPECT_EQ(d.od(comm, od::kPdoTransmissionType), type) << "node " << int{node} << std::hex << " 0x" << comm;
      ASSERT_EQ(d.od(map, od::kPdoMappingCount), m.count) << "node " << int{node} << std::hex << " 0x" << map;
      for (std::size_t k = 0; k < m.count; ++k) {
        EXPECT_EQ(d.od(map, static_cast<std::uint8_t>(k + 1)), m.objects[k].entry()) << "node " << int{node} << std::hex << " 0x" << map;
      }
    }
  };
  expect_table_mapping(b.bus.drive(0), 1, /*factory=*/true);
  b.bus.run_until(b.clock.now() + 150 * kNanosPerMilli);  // the drives boot (0.1 s); the master has not run yet
  for (std::size_t i = 0; i < b.bus.drives(); ++i) {
    hil::DriveNode& d = b.bus.drive(i);
    const auto node = static_cast<std::uint8_t>(i + 1);
    auto write = [&](SdoAddress a, std::uint32_t v, std::size_t size) {
      const std::uint8_t le[4] = {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16),
                                  static_cast<std::uint8_t>(v >> 24)};
      d.on_frame(sdo_download(node, a, {le, size}), b.clock.now());
      ASSERT_EQ(d.outbox().size(), 1u);
      EXPECT_EQ(decode_sdo_response(d.outbox().front()).type, SdoResponse::Type::kDownloadAck) << std::hex << a.index;
      d.outbox().clear();
    };
    for (const PdoMapping& m : pdo_map::kDrive) {
      write({communication_index(m), od::kPdoCobId}, od::kPdoDisabled | cob_id(m, node), 4);
      write({communication_index(m), od::kPdoTransmissionType}, 254, 1);
      write({mapping_index(m), od::kPdoMappingCount}, 1, 1);
      for (std::uint8_t sub = 1; sub <= m.count; ++sub) write({mapping_index(m), sub}, mapping_entry(od::kModesOfOperationDisplay, 0, 8), 4);
    }
  }
  ASSERT_GT(b.until([&] { return b.enabled(); }, 5.0), 0) << b.events();
  for (std::size_t i = 0; i < b.bus.drives(); ++i) expect_table_mapping(b.bus.drive(i), static_cast<std::uint8_t>(i + 1), false);
  // RPDO1: the controlword and a negative target velocity reach the drive.
  const std::int32_t cmd[] = {23456, -34567};
  b.master.command(cmd);
  b.run_for(0.5);  // past the ramp (400000/s): the drives turn at exactly the target
  for (std::size_t i = 0; i < 2; ++i) {
    const hil::DriveNode& d = b.bus.drive(i);
    EXPECT_EQ(d.od(od::kControlword, 0), cia402::cw::kEnableOperation);
    EXPECT_EQ(d.target_velocity(), cmd[i]);
    EXPECT_EQ(d.velocity(), cmd[i]);
    // TPDO1: statusword and velocity actual, as the drive put them in.
    EXPECT_EQ(b.master.drive_state(i), d.state());
    EXPECT_EQ(b.master.feedback(i).velocity, static_cast<std::int32_t>(d.od(od::kVelocityActual, 0)));
    EXPECT_EQ(b.master.feedback(i).velocity, cmd[i]);
  }
  // TPDO2: position actual, at rest (so it does not move between the TPDO and the check);
  // drive 2 went backwards.
  const std::int32_t zero[] = {0, 0};
  b.master.command(zero);
  b.run_for(0.5);
  for (std::size_t i = 0; i < 2; ++i) {
    const hil::DriveNode& d = b.bus.drive(i);
    ASSERT_EQ(d.velocity(), 0.0);
    EXPECT_EQ(b.master.feedback(i).position, static_cast<std::int32_t>(d.od(od::kPositionActual, 0)));
    EXPECT_NEAR(b.master.feedback(i).position, static_cast<double>(d.position()), 1.0);
  }
  EXPECT_GT(b.master.feedback(0).position, 5000);
  EXPECT_LT(b.master.feedback(1).position, -5000);
  // The controlword of disable_all, through the same RPDO.
  b.master.disable_all("test");
  EXPECT_EQ(b.bus.drive(0).od(od::kControlword, 0), cia402::cw::kSwitchOn);
  EXPECT_EQ(b.bus.drive(1).state(), cia402::State::kSwitchedOn);
}

TEST(CanopenSim, TheSameRunGivesTheSameBusTraffic) {
  auto run = [] {
    SimBench b;
    b.until([&] { return b.enabled(); }, 5.0);
    const std::int32_t cmd[] = {10000, -10000};
    b.master.command(cmd);
    b.run_for(0.5);
    b.bus.drive(0).over_current(b.clock.now());
    b.run_for(1.0);
    std::string s;
    for (const auto& e : b.bus.log()) {
      s += std::to_string(e.time) + ":" + std::to_string(e.frame.id) + ":" +
           std::string(reinterpret_cast<const char*>(e.frame.data.data()), e.frame.len) + ";";
    }
    return s;
  };
  const std::string a = run(), c = run();
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, c);
}

}  // namespace
}  // namespace cairn
