// One robot end to end on the HIL bench, in process: the executive drives the office
// world's corridor loop through its real drivers (LMS2xx over a pty, CiA 402 drives on a
// CAN bus, the power board over Modbus TCP; on the VM bench, tests/vm/guest-checks.sh,
// the production backends: SocketCAN, and a UART opened with libserialport). Checks:
// local drift vs ground truth <= 1 % of distance, features land on the world's poles,
// outputs in order; zero allocations on the RT and I/O threads after start-up, in every
// test, so on its failure paths too; the e-stop latches (released, the robot stays
// stopped until a reset) and takes the torque off within 20 ms of the input changing on
// the board, measured through the real Modbus and CANopen traffic; a silent power board,
// a silent drive and a hung CAN thread each stop the robot within 100 ms; the other
// faults stop the robot with their reason and it recovers; on the VM bench, SocketCAN
// link-down and bus-off stop it and it recovers.
#include <gtest/gtest.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "firmware/executive/devices.hpp"
#include "firmware/executive/executive.hpp"
#include "firmware/executive/path_follower.hpp"
#include "hil/bench/robot_bench.hpp"
#include "tests/support/cpu_stall_witness.hpp"
#include "tests/support/pty_baud.hpp"
#include "tests/support/timing.hpp"
#ifndef CAIRN_SANITIZED
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn {
namespace {

std::atomic<std::uint64_t> g_allocations{0};
std::atomic<int> g_counted_threads{0};
void on_steady(const char*) {
#ifndef CAIRN_SANITIZED
  testing::start_counting_allocations();
#endif
}
void on_finished([[maybe_unused]] const char* name) {
#ifndef CAIRN_SANITIZED
  const std::uint64_t n = testing::stop_counting_allocations();
  if (n) std::printf("thread %s: %llu allocations after start-up\n", name, static_cast<unsigned long long>(n));
  g_allocations += n;
  ++g_counted_threads;
#endif
}

// The VM bench (scripts/vm-bench.sh) runs this test inside a guest with a real kernel:
// there the devices are the production backends, named by the environment. The drives
// answer on a SocketCAN interface (CAIRN_VM_CAN, e.g. vcan0) that the executive opens as
// socketcan:IFACE; the laser emulator serves a 16550 UART (CAIRN_VM_LMS_UART) whose
// null-modem partner the executive opens through libserialport (CAIRN_VM_LMS_URI, e.g.
// serial:/dev/ttyS1) at CAIRN_VM_LMS_BAUD (a 16550 tops out at 115200: 38400), the rate
// the emulated laser sits at there (RobotBenchConfig::lms_uart_baud says why).
const char* vm_env(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? v : nullptr;
}
bool on_vm_bench() { return vm_env("CAIRN_VM_CAN") != nullptr; }
std::uint32_t vm_lms_baud() {
  const char* baud = vm_env("CAIRN_VM_LMS_BAUD");
  return baud ? static_cast<std::uint32_t>(std::atol(baud)) : 38400;
}

// The laser on a pty where it carries 500 kBd, else (under qemu-user) on TCP; on the VM
// bench the production backends.
hil::RobotBenchConfig laser_link(hil::RobotBenchConfig bc) {
  if (on_vm_bench()) {
    bc.can_iface = vm_env("CAIRN_VM_CAN");
    bc.lms_uart = vm_env("CAIRN_VM_LMS_UART") ? vm_env("CAIRN_VM_LMS_UART") : "/dev/ttyS2";
    bc.lms_host_uri = vm_env("CAIRN_VM_LMS_URI") ? vm_env("CAIRN_VM_LMS_URI") : "serial:/dev/ttyS1";
    bc.lms_uart_baud = vm_lms_baud();
    std::printf("VM bench: drives on socketcan:%s, laser on %s (emulator on %s)\n", bc.can_iface.c_str(),
                bc.lms_host_uri.c_str(), bc.lms_uart.c_str());
    return bc;
  }
  std::string why;
  if (!testing::pty_carries_500k(&why)) {
    std::printf("laser over TCP: %s\n", why.c_str());
    bc.lms_tcp = true;
  }
  return bc;
}

// The CAN port with a fault: hang() stalls every call into it, as a CAN thread stuck in a
// driver call would be (the executive's CAN thread stops cycling).
class HangablePort final : public can::Port {
 public:
  explicit HangablePort(std::unique_ptr<can::Port> inner) : inner_(std::move(inner)) {}
  void hang(bool h) { hang_.store(h); }
  can::SendResult send(const can::Frame& f, Nanos deadline) override {
    wait();
    return inner_->send(f, deadline);
  }
  bool receive(can::Frame* f, Nanos timeout) override {
    wait();
    return inner_->receive(f, timeout);
  }
  const can::BusStats& stats() const override { return inner_->stats(); }
  bool bus_off() const override { return inner_->bus_off(); }
  IoError restart() override { return inner_->restart(); }
  std::string describe() const override { return inner_->describe(); }
  void pause(Nanos until) override { inner_->pause(until); }

 private:
  void wait() {
    while (hang_.load()) usleep(1000);
  }
  std::unique_ptr<can::Port> inner_;
  std::atomic<bool> hang_{false};
};

struct Harness {
  hil::World world = hil::World::load(std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world");
  hil::RobotBench bench;
  firmware::ExecutiveConfig cfg;
  std::unique_ptr<firmware::Executive> exec;
  HangablePort* can_port = nullptr;
  std::uint32_t last_odom_seq = 0, last_laser_seq = 0, last_feature_seq = 0;
  std::int64_t last_t1 = 0;
  std::uint64_t out_of_order = 0, odometry = 0, lasers = 0, landmark_obs = 0, landmark_near_pole = 0;
  Pose2 start;

  // realtime: ask for the production scheduling (SCHED_FIFO; granted to root, as in CI),
  // with the RT loop on `rt_cpu` (-1: any). stale_scale stretches the stale-input timeouts
  // (power board, wheel feedback, CAN thread) for a test whose subject is not them.
  explicit Harness(const hil::RobotBenchConfig& bc = {}, bool realtime = false, int rt_cpu = -1, double stale_scale = 1.0)
      : bench(world, laser_link(bc)), start(bc.start) {
    std::printf("devices: laser %s, CAN %s, power board %s\n", bench.lms_uri().c_str(), bench.can_uri().c_str(),
                bench.power_uri().c_str());
    bench.start();
    cfg.lms_uri = bench.lms_uri();
    cfg.can_uri = bench.can_uri();
    cfg.power_uri = bench.power_uri();
    cfg.laser_mount = bc.laser_mount;
    if (on_vm_bench()) cfg.lms.target_baud = vm_lms_baud();  // the rate the laser sits at there
    cfg.safety.max_v = 1.0;
    cfg.safety.power_timeout = static_cast<Nanos>(static_cast<double>(cfg.safety.power_timeout) * stale_scale);
    cfg.safety.feedback_timeout = static_cast<Nanos>(static_cast<double>(cfg.safety.feedback_timeout) * stale_scale);
    cfg.rt_loop = {};  // other tests run as an unprivileged user would
    cfg.io_threads = {};
    cfg.map_worker = {};
    if (realtime) {
      cfg.rt_loop = {80, rt_cpu, false};
      cfg.io_threads = {70, -1, false};
      cfg.map_worker = {50, -1, false};
    }
    auto& clock = MonotonicClock::instance();
    firmware::ExecutiveDevices devices = firmware::open_devices(cfg, clock, [] { return false; });
    auto port = std::make_unique<HangablePort>(std::move(devices.can));
    can_port = port.get();
    devices.can = std::move(port);
    exec = std::make_unique<firmware::Executive>(cfg, clock, std::move(devices), firmware::ThreadHooks{on_steady, on_finished});
    exec->start();
  }
  ~Harness() {
    exec->stop();
    bench.stop();
  }
  // The non-RT side for one tick: drain outputs (checking order), follow, keep the link.
  void tick(firmware::PathFollower* follower, bool link = true) {
    const Nanos now = MonotonicClock::instance().now();
    msg::OdometryIncrement inc;
    while (exec->pop_odometry(&inc)) {
      if (inc.seq != last_odom_seq + 1 || inc.t1 < last_t1) ++out_of_order;
      last_odom_seq = inc.seq;
      last_t1 = inc.t1;
      ++odometry;
    }
    static msg::LaserScan scan;
    while (exec->pop_laser(&scan)) {
      if (scan.seq != last_laser_seq + 1) ++out_of_order;
      last_laser_seq = scan.seq;
      ++lasers;
    }
    static msg::FeatureObservations f;
    while (exec->pop_features(&f)) {
      if (f.seq != last_feature_seq + 1) ++out_of_order;
      last_feature_seq = f.seq;
      const Pose2 local{f.local_pose.x, f.local_pose.y, f.local_pose.theta};
      for (int i = 0; i < f.n_features; ++i) {
        if (f.features[i].kind != msg::FeatureKind::kLandmark) continue;
        const Vec2 p = transform_point(start, point_from_observation(local, {f.features[i].range, f.features[i].bearing}));
        double best = 1e9;
        for (const Vec2& pole : world.poles()) best = std::min(best, (pole - p).norm());
        ++landmark_obs;
        if (best < 0.15) ++landmark_near_pole;
      }
    }
    if (link) exec->note_link(now);
    static Nanos next_print = 0;
    if (std::getenv("CAIRN_TEST_VERBOSE") && now > next_print) {
      next_print = now + kNanosPerSecond;
      const auto s = exec->rt_snapshot();
      const Pose2 t = truth_local();
      std::printf("local %.2f %.2f %.2f truth %.2f %.2f %.2f stop %s v %.2f w %.2f scans %llu matched %llu\n", s.local_pose.x,
                  s.local_pose.y, s.local_pose.theta, t.x, t.y, t.theta, firmware::stop_reason_text(s.stop), s.v, s.w,
                  static_cast<unsigned long long>(s.scans), static_cast<unsigned long long>(s.matched));
      std::fflush(stdout);
    }
    double v = 0, w = 0;
    if (follower) {
      const auto s = exec->rt_snapshot();
      follower->command(s.local_pose, s.v, &v, &w);
    }
    exec->set_velocity(v, w, now);
  }
  template <typename F>
  double run_until(F done, double timeout_s, firmware::PathFollower* follower = nullptr, bool link = true) {
    auto& clock = MonotonicClock::instance();
    const Nanos t0 = clock.now(), end = t0 + seconds_to_nanos(timeout_s);
    while (clock.now() < end) {
      tick(follower, link);
      if (done()) return nanos_to_seconds(clock.now() - t0);
      clock.sleep_until(clock.now() + 20 * kNanosPerMilli);
    }
    return -1;
  }
  Pose2 truth_local() const { return between(start, bench.truth().pose); }
};

double ms_of(Nanos d) { return nanos_to_seconds(d) * 1e3; }

// Every test: the RT and I/O threads allocate nothing after start-up (the failure paths
// each test drives included), counted per thread by the hooks of its one Harness, whose
// threads have finished when TearDown runs. Not under a sanitizer (its own allocator).
class ExecutiveHil : public ::testing::Test {
 protected:
  void SetUp() override {
    g_allocations = 0;
    g_counted_threads = 0;
  }
  void TearDown() override {
#ifndef CAIRN_SANITIZED
    if (IsSkipped() || HasFatalFailure()) return;  // no Harness, or one that never ran
    EXPECT_EQ(g_counted_threads.load(), 5);
    EXPECT_EQ(g_allocations.load(), 0u) << "heap allocations on the RT and I/O threads after start-up";
#endif
  }
};

TEST_F(ExecutiveHil, CorridorLoopDriftFeaturesOrderAndNoAllocations) {
  Pose2 end_local, end_truth;
  double odometer = 0;
  [[maybe_unused]] bool rt_granted = false;  // read only in unsanitized builds
  firmware::RtSnapshot snap;
  [[maybe_unused]] Nanos loop_from = 0, loop_to = 0;  // the RT loop's life, for the witness's stalls (unsanitized)
  // The RT loop on the last CPU, watched there by a witness one priority above it: a
  // machine that is itself a VM loses whole milliseconds of a CPU to its host now and then
  // (CI once saw an 8 ms gap), which no scheduling inside it can prevent.
  const bool realtime = testing::timing_slack() == 1.0;
  const bool short_loop = !realtime;
  const int rt_cpu = testing::last_allowed_cpu();
  // Only with the production scheduling: under qemu or a sanitizer a FIFO thread would
  // starve the emulators beside it.
  std::optional<testing::CpuStallWitness> witness;
  if (realtime && rt_cpu >= 0) witness.emplace(rt_cpu, 81);
  {
    hil::RobotBenchConfig bc;
    bc.start = {5.0, 10.0, 0.0};
    // The production scheduling natively; not under sanitizers or qemu, where SCHED_FIFO
    // threads running 5-15x slower starve the emulators beside them.
    // Under qemu-user a CAN or Modbus thread starved for 50 ms is the emulation, not the
    // robot, and the latch it sets would end the drive: the timeouts stretch with the slack
    // (StaleInputsStopWithinTheirBounds measures them at their production values).
    loop_from = MonotonicClock::instance().now();
    Harness h(bc, realtime, rt_cpu, testing::timing_slack());
    ASSERT_GT(h.run_until([&] { return h.exec->rt_snapshot().stop == firmware::StopReason::kNone; }, 10.0), 0)
        << "never ready: stop reason " << firmware::stop_reason_text(h.exec->rt_snapshot().stop);
    // Written by the RT thread before its first snapshot, which the line above has read.
    // The production scheduling, on the witness's CPU (an affinity refused is not it).
    rt_granted = h.exec->rt_reports()[3].find("SCHED_FIFO 80, on CPU " + std::to_string(rt_cpu)) != std::string::npos;
    std::printf("%s\n", h.exec->rt_reports()[3].c_str());
    // Along the corridor's centre line (its poles stand 0.5-0.8 m off it): east to the end,
    // back west, east again (~51 m). Waypoints in the world, followed in the local frame.
    // Where the timing is scaled (sanitizers, qemu-user, the VM bench) the question is memory
    // and thread safety or the backends, not the drift figure: east and back (~34 m), which
    // still turns round and matches against the keyframes of the way out.
    std::vector<Vec2> world_path = {{22, 10}, {4.8, 10}, {21.5, 10}};
    if (short_loop) world_path.pop_back();
    std::vector<Vec2> local_path;
    for (const Vec2& p : world_path) local_path.push_back(inverse_transform_point(h.start, p));
    firmware::FollowerConfig fc;
    fc.speed = 1.0;
    // This loop steers from the test thread every 20 ms. Under qemu or a sanitizer that loop
    // runs several times slower, and pure pursuit at 1 m/s with a lookahead that shortens
    // while the robot speeds up after a turn-around then oscillates until the robot hits a
    // pole. Steering is not what this test checks, so it looks 1.2 m ahead at every speed there.
    if (testing::timing_slack() > 1.0) fc.lookahead_min = fc.lookahead_max = 1.2;
    firmware::PathFollower follower(local_path, fc);
    ASSERT_GT(h.run_until([&] { return follower.done(); }, 150.0, &follower), 0) << "path not finished";
    h.run_until([] { return false; }, 0.5);  // stand still, drain
    end_local = h.exec->rt_snapshot().local_pose;
    end_truth = h.truth_local();
    odometer = h.bench.truth().odometer;
    snap = h.exec->rt_snapshot();
    loop_to = MonotonicClock::instance().now();
    EXPECT_EQ(h.out_of_order, 0u);
    if (on_vm_bench()) {
      EXPECT_EQ(h.bench.lms().uart_baud_refused(), 0u) << "the laser's UART refused its rate";
    }
    // One increment per scan, every 10th scan sent on: at 500 kBd the laser gives 75 scans
    // a second over the ~55 s drive; on the VM bench's 38400 Bd UART a 361-beam telegram
    // takes 0.19 s, about 5 a second.
    const std::uint64_t min_scans = on_vm_bench() ? 150 : 1000;
    EXPECT_GT(h.odometry, min_scans);
    EXPECT_GT(h.lasers, min_scans / 10);
    EXPECT_GT(h.landmark_obs, short_loop ? 130u : 200u);
    // A landmark lands within 15 cm of its pole only if the scan's stamp (and so the pose it is
    // placed from) is close to when the laser took it. Natively that lag is well under a
    // millisecond; under qemu or a sanitizer the I/O thread wakes tens of ms late (p99 period
    // ~70 ms at 1 m/s is ~7 cm), so the bound there is looser.
    const double near_share = testing::timing_slack() > 1.0 ? 0.90 : 0.95;
    EXPECT_GT(static_cast<double>(h.landmark_near_pole), near_share * static_cast<double>(h.landmark_obs));
    std::printf("landmark observations %llu, %.1f %% within 15 cm of a pole\n",
                static_cast<unsigned long long>(h.landmark_obs), 100.0 * static_cast<double>(h.landmark_near_pole) / static_cast<double>(h.landmark_obs));
  }
  const double drift = std::hypot(end_local.x - end_truth.x, end_local.y - end_truth.y);
  std::printf("travelled %.1f m; local pose error %.3f m = %.2f %% (heading %.2f deg); scans %llu, matched %llu\n",
              odometer, drift, 100 * drift / odometer, std::abs(normalize_angle(end_local.theta - end_truth.theta)) * 57.3,
              static_cast<unsigned long long>(snap.scans), static_cast<unsigned long long>(snap.matched));
  if (witness) witness->stop();
  std::printf("RT loop: period mean %.1f us, p99 %.1f us, max jitter %.1f us, %llu cycles, %llu deadline misses; scan work p99 %.0f us, max %.0f us\n",
              static_cast<double>(snap.period_mean_us), static_cast<double>(snap.period_p99_us), static_cast<double>(snap.jitter_max_us), static_cast<unsigned long long>(snap.cycles),
              static_cast<unsigned long long>(snap.misses), static_cast<double>(snap.scan_work_p99_us), static_cast<double>(snap.scan_work_max_us));
  if (witness) {
    std::printf("CPU %d taken by the platform (witness at SCHED_FIFO 81%s): %zu stalls > 0.1 ms (%zu not logged), longest %.2f ms, total %.1f ms\n",
                rt_cpu, witness->granted() ? "" : " NOT granted", witness->stalls(), witness->dropped(), ms_of(witness->longest()),
                ms_of(witness->total()));
  }
  EXPECT_GT(odometer, short_loop ? 30.0 : 45.0);
  EXPECT_LT(drift, 0.01 * odometer);
  EXPECT_GT(snap.matched, snap.scans * 9 / 10);
  EXPECT_EQ(snap.overflows, 0u);
#ifndef CAIRN_SANITIZED
  // With the production scheduling no control cycle may finish a whole period late. Not
  // under qemu-user (timing slack > 1), where the emulated CPU is several times slower.
  // A miss counts against Cairn when the cycle, less the time the witness saw the platform
  // take from that CPU, still ran more than a period past its deadline. The witness wakes
  // on a 0.25 ms grid, so up to that much of each stall it saw goes unseen: the allowance
  // is one grid step per overlapping stall, none when it saw none (then this is the strict
  // zero-miss check). Without a granted witness, or with stalls it could not log, strict.
  if (rt_granted && realtime) {
    const bool attributable = witness && witness->granted() && witness->dropped() == 0;
    EXPECT_TRUE(attributable) << "the stall witness was not granted SCHED_FIFO 81 on CPU " << rt_cpu << " or lost stalls";
    // The period's 99th percentile within 20 % of the period (seen: 10,060-10,240 us): a
    // loop that overran its period by 2 ms in 1 % of its cycles fails. The platform alone
    // cannot move the p99 that far while its own stalls of more than 2 ms (the witness's,
    // during the loop's life) hit under 1 % of the cycles (usually two or three dozen of
    // ~5,800). A hypervisor that takes the CPU that long more often (one noisy run here:
    // 7,095 stalls, 4.2 s of 58 s, p99 13.3 ms) gets the wider bound of 2 periods, which
    // a loop that overran by a whole period in 1 % of its cycles still fails.
    const Nanos period_ns = firmware::ExecutiveConfig{}.period;
    const std::size_t long_stalls = attributable ? witness->longer_than(period_ns / 5, loop_from, loop_to) : 0;
    const bool quiet_platform = long_stalls * 100 < snap.cycles;
    std::printf("platform stalls of the RT CPU longer than 2 ms during the loop: %zu in %llu cycles: p99 bound %s\n", long_stalls,
                static_cast<unsigned long long>(snap.cycles), quiet_platform ? "1.2 periods" : "2 periods (noisy platform)");
    EXPECT_LE(static_cast<double>(snap.period_p99_us), (quiet_platform ? 1.2 : 2.0) * nanos_to_seconds(period_ns) * 1e6)
        << "p99 of the RT period";
    if (!attributable) {
      EXPECT_EQ(snap.misses, 0u) << "deadline misses with SCHED_FIFO";
    } else {
      EXPECT_LE(snap.misses, snap.first_misses.size()) << "more deadline misses than the log holds";
      const Nanos period = period_ns;  // the harness keeps the default
      for (std::size_t i = 0; i < std::min(static_cast<std::size_t>(snap.misses), snap.first_misses.size()); ++i) {
        const auto& m = snap.first_misses[i];
        std::size_t stalls = 0;
        const Nanos late = m.finished - m.deadline, taken = witness->stolen(m.deadline, m.finished, &stalls);
        std::printf("deadline miss: finished %.2f ms after its deadline, %.2f ms of it taken by the platform in %zu stalls\n",
                    ms_of(late), ms_of(taken), stalls);
        EXPECT_LE(late - taken, period + static_cast<Nanos>(stalls) * testing::CpuStallWitness::kGrid)
            << "a deadline miss of Cairn's own with SCHED_FIFO";
      }
    }
  }
#endif
}

// Helpers for the fault tests: times are MonotonicClock, shared by the emulators and the test.
Nanos now_ns() { return MonotonicClock::instance().now(); }
// Polls `when()` (a recorded time, 0 = not yet) every 0.5 ms until it is after `after`;
// returns it, or 0 after `limit`.
template <typename F>
Nanos wait_recorded(F when, Nanos after, Nanos limit) {
  const Nanos end = now_ns() + limit;
  while (now_ns() < end) {
    const Nanos t = when();
    if (t > after) return t;
    usleep(500);
  }
  return 0;
}
// Both drives' torque off (left operation enabled on a received controlword) after `after`:
// the later of the two, or 0.
Nanos torque_off_both(Harness& h, Nanos after, Nanos limit) {
  return wait_recorded([&] {
    const Nanos a = h.bench.drive(0).with_node([](hil::DriveNode& n) { return n.torque_off_at(); });
    const Nanos b = h.bench.drive(1).with_node([](hil::DriveNode& n) { return n.torque_off_at(); });
    return a > after && b > after ? std::max(a, b) : Nanos{0};
  }, after, limit);
}
bool drive_enabled(Harness& h, int i) {
  return h.bench.drive(i).with_node([](hil::DriveNode& n) { return n.state(); }) == cia402::State::kOperationEnabled;
}

// Stays stopped for `seconds` while the follower keeps asking to move: zero commanded, no
// drive enabled, the body still (odometer +< 5 mm), reason `want` throughout.
void expect_stays_stopped(Harness& h, firmware::PathFollower* follower, double seconds, firmware::StopReason want) {
  std::uint64_t wrong = 0, samples = 0;
  // The body first coasts to rest (a disabled drive ramps its motor down): until the
  // odometer moves < 0.1 mm in 100 ms; then it must not move at all.
  double odo = -1;
  const double settle = h.run_until([&] {
    const double o = h.bench.truth().odometer;
    const bool still = o - odo < 1e-4;
    odo = o;
    usleep(80000);
    return still;
  }, 3.0, follower);
  ASSERT_GT(settle, 0) << "the robot did not come to rest";
  const double odo0 = h.bench.truth().odometer;
  h.run_until([&] {
    const auto s = h.exec->rt_snapshot();
    ++samples;
    if (s.v != 0.0 || s.stop != want || drive_enabled(h, 0) || drive_enabled(h, 1)) ++wrong;
    return false;
  }, seconds, follower);
  EXPECT_GT(samples, 10u);
  EXPECT_EQ(wrong, 0u) << "moved, enabled a drive or changed its reason while it had to stay stopped (" << samples << " samples); reason now "
                       << firmware::stop_reason_text(h.exec->rt_snapshot().stop);
  EXPECT_LT(h.bench.truth().odometer - odo0, 0.005) << "the robot moved while latched";
}

TEST_F(ExecutiveHil, EstopLatchesTorqueOffWithin20msAndOnlyAResetRestarts) {
  Harness h;
  using firmware::StopReason;
  auto reason = [&] { return h.exec->rt_snapshot().stop; };
  ASSERT_GT(h.run_until([&] { return reason() == StopReason::kNone; }, 10.0), 0);
  firmware::FollowerConfig fc;
  fc.speed = 0.3;
  firmware::PathFollower follower({{15.0, 0.0}}, fc);
  auto moving = [&] { return std::abs(h.exec->rt_snapshot().v) > 0.05; };
  hil::PowerEmulator& board = h.bench.power();
  ASSERT_GT(h.run_until(moving, 3.0, &follower), 0);
  EXPECT_TRUE(board.motor_relay()) << "the executive switches motor power on at start";

  std::vector<double> press_to_torque_off, press_to_relay_off;
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE("press " + std::to_string(k + 1));
    ASSERT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());
    h.run_until([] { return false; }, 0.2, &follower);  // at speed, both drives enabled
    ASSERT_TRUE(drive_enabled(h, 0) && drive_enabled(h, 1));
    // Press: the input changes on the board (its time recorded there); torque off is when
    // the drives receive the controlword that takes them out of operation enabled.
    board.press_estop(true);
    const Nanos pressed = board.estop_changed_at();
    const Nanos off = torque_off_both(h, pressed, kNanosPerSecond);
    ASSERT_GT(off, 0) << "the drives never left operation enabled";
    press_to_torque_off.push_back(ms_of(off - pressed));
    const Nanos relay_off = wait_recorded([&] { return board.relay_off_written_at(); }, pressed, kNanosPerSecond);
    ASSERT_GT(relay_off, 0) << "motor power was never switched off through the board";
    press_to_relay_off.push_back(ms_of(relay_off - pressed));
    EXPECT_GT(h.run_until([&] { return reason() == StopReason::kEstop; }, 1.0, &follower), 0);
    EXPECT_TRUE(h.exec->rt_snapshot().latched);
    // A reset while the e-stop is pressed is refused and forgotten.
    if (k == 0) {
      const auto refused = h.exec->rt_snapshot().resets_refused;
      h.exec->request_reset();
      EXPECT_GT(h.run_until([&] { return h.exec->rt_snapshot().resets_refused > refused; }, 1.0, &follower), 0);
      EXPECT_EQ(reason(), StopReason::kEstop);
    }
    // Release: latched, stopped, motor power stays off, for as long as nobody resets.
    board.press_estop(false);
    const Nanos released = now_ns();
    EXPECT_GT(h.run_until([&] { return reason() == StopReason::kResetRequired; }, 1.0, &follower), 0);
    expect_stays_stopped(h, &follower, k == 0 ? 2.0 : 0.5, StopReason::kResetRequired);
    EXPECT_FALSE(board.motor_relay());
    EXPECT_LT(board.relay_on_written_at(), released) << "motor power switched on without a reset";
    // The reset: the robot's own API (the DDS SafetyReset and SIGUSR1 call it) or, every
    // other press, the board's reset input (a 30 ms push of the button).
    const Nanos reset_at = now_ns();
    if (k % 2 == 0) {
      h.exec->request_reset();
    } else {
      board.press_reset(true);
      usleep(30000);
      board.press_reset(false);
    }
    EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << "no motion after the reset: " << firmware::stop_reason_text(reason());
    EXPECT_GT(board.relay_on_written_at(), reset_at) << "motor power not switched on by the reset";
    EXPECT_TRUE(board.motor_relay());
    EXPECT_FALSE(h.exec->rt_snapshot().latched);
  }
  std::sort(press_to_torque_off.begin(), press_to_torque_off.end());
  std::sort(press_to_relay_off.begin(), press_to_relay_off.end());
  std::printf("e-stop input change on the board -> torque off at both drives (CiA 402 controlword on CAN): "
              "min %.2f, median %.2f, max %.2f ms over %zu presses; -> motor relay off written: max %.2f ms\n",
              press_to_torque_off.front(), press_to_torque_off[press_to_torque_off.size() / 2], press_to_torque_off.back(),
              press_to_torque_off.size(), press_to_relay_off.back());
  EXPECT_LE(press_to_torque_off.back(), 20.0 * testing::timing_slack());
  EXPECT_LE(press_to_relay_off.back(), 20.0 * testing::timing_slack());
  EXPECT_EQ(h.exec->rt_snapshot().resets_accepted, 6u);

  // The base's remote e-stop (the bridge calls request_remote_stop on a SafetyStop): torque
  // off and motor power off as on a press, latched with its own cause until a reset.
  ASSERT_GT(h.run_until(moving, 10.0, &follower), 0);
  h.run_until([] { return false; }, 0.2, &follower);
  const Nanos asked = now_ns();
  h.exec->request_remote_stop();
  const Nanos off = torque_off_both(h, asked, kNanosPerSecond);
  ASSERT_GT(off, 0) << "a remote stop left the drives in operation enabled";
  const Nanos relay_off = wait_recorded([&] { return board.relay_off_written_at(); }, asked, kNanosPerSecond);
  ASSERT_GT(relay_off, 0) << "a remote stop did not switch motor power off";
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kResetRequired; }, 1.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().latch_cause, firmware::LatchCause::kRemoteStop);
  EXPECT_EQ(h.exec->rt_snapshot().remote_stops, 1u);
  // A network reset asked for before this stop (it saw no remote stop) is refused, counted;
  // the robot stays latched. One that saw it is taken.
  EXPECT_FALSE(h.exec->request_reset(0u));
  expect_stays_stopped(h, &follower, 0.5, StopReason::kResetRequired);
  EXPECT_EQ(h.exec->rt_snapshot().resets_predating, 1u);
  EXPECT_TRUE(h.exec->request_reset(1u));
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << "no motion after the reset of a remote stop";
  std::printf("remote e-stop -> torque off at both drives: %.2f ms, motor relay off written: %.2f ms\n", ms_of(off - asked),
              ms_of(relay_off - asked));
  EXPECT_LE(ms_of(off - asked), 20.0 * testing::timing_slack());
}

// The power thread's snapshot reason ("ok, ..." or the failed transaction).
std::string power_reason(Harness& h) {
  std::array<firmware::DeviceSnapshot, 4> d;
  h.exec->devices(&d);
  return d[3].reason.data();
}

// The fixture's allocation check covers these failure paths: a failed battery poll and
// relay write while the board is silent, a silent drive, a hung CAN port.
TEST_F(ExecutiveHil, StaleInputsStopWithinTheirBounds) {
  Harness h;
  using firmware::StopReason;
  auto reason = [&] { return h.exec->rt_snapshot().stop; };
  ASSERT_GT(h.run_until([&] { return reason() == StopReason::kNone; }, 10.0), 0);
  firmware::FollowerConfig fc;
  fc.speed = 0.3;
  firmware::PathFollower follower({{15.0, 0.0}}, fc);
  auto moving = [&] { return std::abs(h.exec->rt_snapshot().v) > 0.05; };
  hil::PowerEmulator& board = h.bench.power();
  const double bound_ms = 100.0 * testing::timing_slack();

  // The power board goes silent (its e-stop input can no longer be read): torque off at
  // both drives, then latched until a reset once it answers again.
  ASSERT_GT(h.run_until(moving, 5.0, &follower), 0);
  h.run_until([] { return false; }, 0.2, &follower);
  Nanos t0 = now_ns();
  board.set_silent(true);
  Nanos off = torque_off_both(h, t0, kNanosPerSecond);
  ASSERT_GT(off, 0);
  const double silent_ms = ms_of(off - t0);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kPowerLost; }, 1.0, &follower), 0);
  // Silent for longer than the battery poll's period: a poll fails too (the power thread's
  // snapshot names the failed transaction until a poll succeeds), as do relay writes.
  h.run_until([] { return false; }, nanos_to_seconds(firmware::ExecutiveConfig{}.power_poll) + 0.2, &follower);
  EXPECT_EQ(power_reason(h).rfind("reading input registers", 0), 0u) << "no failed poll while silent: " << power_reason(h);
  board.set_silent(false);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kResetRequired; }, 2.0, &follower), 0);
  expect_stays_stopped(h, &follower, 0.5, StopReason::kResetRequired);
  h.exec->request_reset();
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());

  // A drive stops answering (no TPDO): the other drive is commanded zero; when it is back
  // the robot moves again by itself (the CAN thread could always command zero: no latch).
  h.run_until([] { return false; }, 0.2, &follower);
  t0 = now_ns();
  h.bench.drive(1).with_node([](hil::DriveNode& n) { return (n.set_silent(true), 0); });
  const Nanos zero = wait_recorded([&] { return h.bench.drive(0).with_node([](hil::DriveNode& n) { return n.zero_target_at(); }); },
                                   t0, kNanosPerSecond);
  ASSERT_GT(zero, 0) << "the live drive was never commanded zero";
  const double feedback_ms = ms_of(zero - t0);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kDrivesNotReady; }, 2.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().v, 0.0);
  EXPECT_FALSE(h.exec->rt_snapshot().latched);
  h.bench.drive(1).with_node([](hil::DriveNode& n) { return (n.set_silent(false), 0); });
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());

  // The CAN thread hangs (a dead CAN thread: no command reaches the drives any more): the
  // RT loop sees no fresh wheel feedback and switches motor power off through the board;
  // latched until a reset.
  h.run_until([] { return false; }, 0.2, &follower);
  t0 = now_ns();
  h.can_port->hang(true);
  const Nanos relay_off = wait_recorded([&] { return board.relay_off_written_at(); }, t0, kNanosPerSecond);
  ASSERT_GT(relay_off, 0) << "motor power was not switched off";
  const double can_ms = ms_of(relay_off - t0);
  EXPECT_FALSE(board.motor_relay());
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kFeedbackStale; }, 1.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().latch_cause, firmware::LatchCause::kCanStalled);
  h.can_port->hang(false);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kResetRequired; }, 2.0, &follower), 0);
  expect_stays_stopped(h, &follower, 1.0, StopReason::kResetRequired);
  h.exec->request_reset();
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());
  EXPECT_TRUE(board.motor_relay());

  std::printf("power board silent -> torque off at both drives: %.1f ms; a drive silent -> zero commanded to the other: "
              "%.1f ms; CAN thread hung -> motor relay off written: %.1f ms (bound %.0f ms)\n",
              silent_ms, feedback_ms, can_ms, bound_ms);
  EXPECT_LE(silent_ms, bound_ms);
  EXPECT_LE(feedback_ms, bound_ms);
  EXPECT_LE(can_ms, bound_ms);
}

TEST_F(ExecutiveHil, EveryOtherFaultStopsWithItsReasonAndRecovers) {
  Harness h;
  using firmware::StopReason;
  auto reason = [&] { return h.exec->rt_snapshot().stop; };
  ASSERT_GT(h.run_until([&] { return reason() == StopReason::kNone; }, 10.0), 0);
  firmware::FollowerConfig fc;
  fc.speed = 0.3;
  firmware::PathFollower follower({{15.0, 0.0}}, fc);
  auto moving = [&] { return std::abs(h.exec->rt_snapshot().v) > 0.05; };
  ASSERT_GT(h.run_until(moving, 3.0, &follower), 0);

  // Laser unplugged: stop (laser silent); plugged back: the driver reconnects, we move.
  h.bench.lms().unplug(true);
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kLaserLost; }, 2.0, &follower), 0);
  EXPECT_EQ(h.exec->rt_snapshot().v, 0.0);
  h.bench.lms().unplug(false);
  EXPECT_GT(h.run_until(moving, 10.0, &follower), 0) << firmware::stop_reason_text(reason());

  // Base-station link lost: stop; back: move.
  EXPECT_GT(h.run_until([&] { return reason() == StopReason::kLinkLost; }, 4.0, &follower, false), 0);
  EXPECT_GT(h.run_until(moving, 3.0, &follower), 0);

  // A NaN velocity command is never applied: five RT cycles on it, the output stays finite
  // and ramps towards zero.
  const double v_before = h.exec->rt_snapshot().v;
  h.exec->set_velocity(std::nan(""), std::nan(""), MonotonicClock::instance().now());
  const auto cycles = h.exec->rt_snapshot().cycles;
  while (h.exec->rt_snapshot().cycles < cycles + 5) usleep(2000);
  const auto s = h.exec->rt_snapshot();
  EXPECT_TRUE(std::isfinite(s.v) && std::isfinite(s.w));
  EXPECT_LT(s.v, v_before);
  EXPECT_EQ(h.out_of_order, 0u);
  EXPECT_GE(h.exec->rt_snapshot().stops, 2u);
}

// What a CAN controller's driver reports when its controller goes bus-off: an error frame
// with CAN_ERR_BUSOFF, here written onto the interface by a raw socket of the test's.
bool inject_bus_off(const std::string& iface) {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return false;
  sockaddr_can a{};
  a.can_family = AF_CAN;
  a.can_ifindex = static_cast<int>(if_nametoindex(iface.c_str()));
  can_frame f{};
  f.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  f.len = CAN_ERR_DLC;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && ::write(fd, &f, sizeof f) == sizeof f;
  ::close(fd);
  return ok;
}
// `ip link set IFACE up|down`, in process (SIOCSIFFLAGS): no fork of this busy process.
bool set_link(const std::string& iface, bool up) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ifreq r{};
  std::snprintf(r.ifr_name, sizeof r.ifr_name, "%s", iface.c_str());
  bool ok = fd >= 0 && ::ioctl(fd, SIOCGIFFLAGS, &r) == 0;
  if (ok) {
    r.ifr_flags = static_cast<short>(up ? (r.ifr_flags | IFF_UP) : (r.ifr_flags & ~IFF_UP));
    ok = ::ioctl(fd, SIOCSIFFLAGS, &r) == 0;
  }
  if (fd >= 0) ::close(fd);
  return ok;
}
firmware::DeviceSnapshot can_device(Harness& h) {
  std::array<firmware::DeviceSnapshot, 4> d;
  h.exec->devices(&d);
  return d[1];
}
// Brings the interface back up when a test ends early with it down: the tests after it share it.
struct LinkUpAtExit {
  std::string iface;
  ~LinkUpAtExit() { set_link(iface, true); }
};

// On the VM bench only, where the CAN interface is a real kernel's: the interface goes
// down and comes back, then the controller reports bus-off. Down, the wheels stop within
// the stale-feedback bound; on bus-off the error is counted and the port reopened (vcan
// has no controller, so the bus is never really off and the drives' re-enable can be
// quicker than an RT cycle: no stop is required). Both times the robot drives on by
// itself (the CAN side could always command zero: no latch, as for a silent drive).
TEST_F(ExecutiveHil, SocketCanLinkDownAndBusOffStopAndRecover) {
  if (!on_vm_bench()) GTEST_SKIP() << "needs a SocketCAN interface of a real kernel: runs on the VM bench (scripts/vm-bench.sh)";
  const std::string iface = vm_env("CAIRN_VM_CAN");
  Harness h;
  using firmware::StopReason;
  auto reason = [&] { return h.exec->rt_snapshot().stop; };
  ASSERT_GT(h.run_until([&] { return reason() == StopReason::kNone; }, 10.0), 0);
  firmware::FollowerConfig fc;
  fc.speed = 0.3;
  firmware::PathFollower follower({{15.0, 0.0}}, fc);
  auto moving = [&] { return std::abs(h.exec->rt_snapshot().v) > 0.05; };
  auto stopped = [&] { return reason() != StopReason::kNone && h.exec->rt_snapshot().v == 0.0; };
  const double bound_ms = 100.0 * testing::timing_slack();

  ASSERT_GT(h.run_until(moving, 5.0, &follower), 0);
  h.run_until([] { return false; }, 0.2, &follower);
  const LinkUpAtExit link_up{iface};
  const Nanos t0 = now_ns();
  ASSERT_TRUE(set_link(iface, false));
  const Nanos stop_at = wait_recorded([&] { return stopped() ? now_ns() : Nanos{0}; }, t0, kNanosPerSecond);
  ASSERT_GT(stop_at, 0) << "did not stop with the interface down";
  const double down_ms = ms_of(stop_at - t0);
  const StopReason down_reason = reason();
  h.run_until([] { return false; }, 0.5, &follower);
  EXPECT_TRUE(stopped()) << "moved with the CAN interface down";
  ASSERT_TRUE(set_link(iface, true));
  const double up_s = h.run_until(moving, 10.0, &follower);
  EXPECT_FALSE(h.exec->rt_snapshot().latched);

  h.run_until([] { return false; }, 0.5, &follower);
  const firmware::DeviceSnapshot before = can_device(h);
  ASSERT_TRUE(inject_bus_off(iface));
  h.run_until([] { return false; }, 0.3, &follower);  // the next device snapshot
  const double back_s = h.run_until(moving, 10.0, &follower);
  std::printf("%s down: stopped after %.1f ms (%s; bound %.0f ms), moving %.2f s after it came up; bus-off: moving %.2f s "
              "after it\n", iface.c_str(), down_ms, firmware::stop_reason_text(down_reason), bound_ms, up_s, back_s + 0.3);
  EXPECT_EQ(down_reason, StopReason::kFeedbackStale);
  EXPECT_LE(down_ms, bound_ms);
  EXPECT_GT(up_s, 0) << "did not drive on after the interface came up";
  const firmware::DeviceSnapshot after = can_device(h);
  EXPECT_GT(after.errors, before.errors) << "the bus-off error frame was not counted";
  EXPECT_GT(after.recoveries, before.recoveries) << "the port was not restarted after bus-off";
  EXPECT_GT(back_s, 0) << "did not drive on after the bus-off restart";
  EXPECT_FALSE(h.exec->rt_snapshot().latched);
}

}  // namespace
}  // namespace cairn
