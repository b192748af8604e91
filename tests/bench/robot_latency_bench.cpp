// Robot latency and RT jitter on the HIL bench, in one process so every time is on one
// clock: the LMS2xx emulator records when it wrote each scan telegram's last byte into
// the pty (and when that byte was due on an ideal line); the executive (real drivers, RT
// loop, local mapper) and the production DDS bridge publish the scan's corrected
// OdometryIncrement; a second DDS participant (loopback profile) reads it in its
// data-available listener. Reports last byte written -> corrected pose read on DDS (p50,
// p99, max), the same from the ideal line time (it adds the emulator's own pacing
// lateness, also reported), the RT thread's per-scan work and its period/jitter, first
// with the second core idle (baseline), then with it loaded by a busy thread, in the same
// run. Fails (exit 1) when the p50 or p99 latency (from the write) of either phase exceeds
// --max-p50-ms (default 1.5 ms) or --max-p99-ms (default 2 ms), or too few scans were
// measured. The p50 is what a shared VM cannot spoil: its CPU stalls (6-12 ms, several
// a minute) land on a few scans, i.e. on the p99 of a short run, never on the median.
//   cairn-bench-robot-latency [--seconds 20] [--priority 80] [--max-p50-ms 1.5] [--max-p99-ms 2] [--json]
#include <pthread.h>
#include <sched.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <mutex>
#include <stdexcept>
#include <cstdio>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware/executive/devices.hpp"
#include "firmware/executive/path_follower.hpp"
#include "firmware/robot_bridge.hpp"
#include "hil/bench/robot_bench.hpp"
#include "tests/support/percentile.hpp"

using namespace cairn;

namespace {

constexpr int kDomain = 109;

// (t1 of the increment, time it was read), filled by the reader's listener.
struct Received {
  MonotonicClock* clock = nullptr;
  std::mutex mutex;
  std::vector<std::pair<Nanos, Nanos>> stamps;
  static void on_data_available(dds_entity_t reader, void* arg) {
    auto* self = static_cast<Received*>(arg);
    const Nanos now = self->clock->now();
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    const dds_return_t n = dds_take(reader, samples, infos, 16, 16);
    std::lock_guard lock(self->mutex);
    for (int i = 0; i < n; ++i) {
      if (infos[i].valid_data) self->stamps.emplace_back(static_cast<const cairn_OdometryIncrement*>(samples[i])->t1_ns, now);
    }
    if (n > 0) dds_return_loan(reader, samples, n);
  }
};

struct Phase {
  std::vector<double> latency_ms;       // last byte written -> read on DDS (the figure)
  std::vector<double> line_latency_ms;  // from when the last byte was due on an ideal line
  std::vector<double> emulator_late_ms; // the emulator's write after that ideal time
  firmware::RtSnapshot rt;
  std::uint64_t unmatched = 0;
};

using cairn::testing::percentile;

Phase run_phase(const std::string& world_path, double seconds, int priority, bool load) {
  const hil::World world = hil::World::load(world_path);
  hil::RobotBenchConfig bc;
  bc.start = {5.0, 10.0, 0.0};
  hil::RobotBench bench(world, bc);
  bench.start();
  firmware::RobotConfig rc;
  rc.id = 1;
  rc.name = "bench";
  rc.dds = dds::loopback_profile(kDomain);
  rc.has_devices = true;
  auto& ec = rc.executive;
  ec.lms_uri = bench.lms_uri();
  ec.can_uri = bench.can_uri();
  ec.power_uri = bench.power_uri();
  ec.safety.link_timeout = 0;
  ec.rt_loop = {priority, 0, priority > 0};  // RT loop on CPU 0; the load goes on CPU 1
  ec.io_threads = {priority > 0 ? priority - 10 : 0, -1, false};
  ec.map_worker = {priority > 0 ? priority - 30 : 0, -1, false};

  dds::Participant robot_pp(rc.dds), listener_pp(dds::loopback_profile(kDomain));
  firmware::RobotBridge bridge(robot_pp, rc);
  dds::Topic<cairn_OdometryIncrement> topic(listener_pp);
  auto& clock = MonotonicClock::instance();
  firmware::Executive exec(ec, clock, firmware::open_devices(ec, clock, [] { return false; }));
  // The second participant reads each increment in its data-available listener, which
  // Cyclone calls as the sample is delivered: the time taken is the robot's, not the
  // wake-up of a thread standing in for the base station's machine.
  Received received;
  received.clock = &clock;
  received.stamps.reserve(static_cast<std::size_t>(seconds + 10) * 200);
  dds_listener_t* on_data = dds_create_listener(&received);
  dds_lset_data_available(on_data, &Received::on_data_available);
  // The robot writes in its own partition (common/dds/partition.hpp); so must the reader read.
  dds_qos_t* sub_qos = dds::make_partition_qos(dds::kAllRobotsPartition);
  const dds_entity_t subscriber = dds_create_subscriber(listener_pp.handle(), sub_qos, nullptr);
  dds_delete_qos(sub_qos);
  if (subscriber < 0) throw std::runtime_error("dds_create_subscriber failed");
  dds_qos_t* qos = dds::make_qos(dds::latched_qos(512));
  const dds_entity_t reader = dds_create_reader(subscriber, topic.handle(), qos, on_data);
  dds_delete_qos(qos);
  dds_delete_listener(on_data);
  if (reader < 0) throw std::runtime_error("dds_create_reader failed");
  exec.start();

  std::atomic<bool> running{true};
  std::thread hog;
  if (load) {
    hog = std::thread([&] {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(std::thread::hardware_concurrency() > 1 ? 1 : 0, &set);
      pthread_setaffinity_np(pthread_self(), sizeof set, &set);
      volatile double x = 1;
      while (running) x = x * 1.0000001 + 1e-9;
    });
  }

  firmware::FollowerConfig fc;
  fc.speed = 0.8;
  fc.loop = true;
  firmware::PathFollower follower({{15, 0}, {0, 0}}, fc);
  const Nanos t0 = clock.now(), end = t0 + seconds_to_nanos(seconds + 3);
  const Nanos measure_from = t0 + 3 * kNanosPerSecond;  // drivers up, robot moving
  Nanos next = t0;
  while (clock.now() < end) {
    const Nanos now = clock.now();
    bridge.forward(exec);
    exec.note_link(now);
    double v = 0, w = 0;
    const auto rt = exec.rt_snapshot();
    follower.command(rt.local_pose, rt.v, &v, &w);
    exec.set_velocity(v, w, now);
    // As cairn-robot's main loop: woken by the RT thread's outputs, else at the tick.
    if (next <= now) next = now + rc.bridge_period;
    const std::uint32_t seen = exec.output_event().value();
    if (!exec.has_output()) clock.wait_event(exec.output_event(), seen, next);
  }
  Phase out;
  out.rt = exec.rt_snapshot();
  exec.stop();
  running = false;
  dds_delete(reader);
  if (hog.joinable()) hog.join();

  // Each received increment belongs to the scan whose sweep started at its t1 (the
  // driver's first-beam estimate); its last byte left at tx_start + bytes on the line.
  std::vector<hil::SentScan> sent;
  std::uint32_t baud = 0;
  bench.lms().with_device([&](hil::LmsDevice& d) {
    sent.assign(d.sent_scans().begin(), d.sent_scans().end());
    baud = d.baud();
    return 0;
  });
  bench.stop();
  std::vector<std::pair<Nanos, Nanos>> stamps;
  {
    std::lock_guard lock(received.mutex);
    stamps = received.stamps;
  }
  for (const auto& [t1, rx] : stamps) {
    if (t1 < measure_from) continue;
    const hil::SentScan* best = nullptr;
    for (const auto& s : sent) {
      if (s.tx_start >= 0 && (!best || std::llabs(s.sweep_start - t1) < std::llabs(best->sweep_start - t1))) best = &s;
    }
    if (!best || std::llabs(best->sweep_start - t1) > 5 * kNanosPerMilli) {
      ++out.unmatched;
      continue;
    }
    const Nanos last_byte = best->tx_start + static_cast<Nanos>(static_cast<double>(best->bytes) * 10.0 / baud * 1e9);
    if (best->last_byte_written < 0) {
      ++out.unmatched;
      continue;
    }
    out.latency_ms.push_back(nanos_to_seconds(rx - best->last_byte_written) * 1e3);
    out.line_latency_ms.push_back(nanos_to_seconds(rx - last_byte) * 1e3);
    out.emulator_late_ms.push_back(nanos_to_seconds(best->last_byte_written - last_byte) * 1e3);
  }
  std::fprintf(stderr, "  %s: %s\n", load ? "loaded" : "idle", exec.rt_reports()[3].c_str());
  return out;
}

}  // namespace

nlohmann::json phase_json(const Phase& p) {
  return {{"scans", p.latency_ms.size()},
          {"unmatched", p.unmatched},
          {"latency_p50_ms", percentile(p.latency_ms, 0.5)},
          {"latency_p99_ms", percentile(p.latency_ms, 0.99)},
          {"latency_max_ms", percentile(p.latency_ms, 1.0)},
          {"line_latency_p50_ms", percentile(p.line_latency_ms, 0.5)},
          {"line_latency_p99_ms", percentile(p.line_latency_ms, 0.99)},
          {"emulator_late_p99_ms", percentile(p.emulator_late_ms, 0.99)},
          {"scan_work_p99_us", p.rt.scan_work_p99_us},
          {"scan_work_max_us", p.rt.scan_work_max_us},
          {"period_p99_us", p.rt.period_p99_us},
          {"jitter_max_us", p.rt.jitter_max_us},
          {"deadline_misses", p.rt.misses}};
}

int main(int argc, char** argv) {
  CLI::App app{"cairn-bench-robot-latency: scan last byte -> corrected pose on DDS, and RT jitter, idle vs loaded core"};
  double seconds = 20, max_p50_ms = 1.5, max_p99_ms = 2.0;
  int priority = 80;
  bool json = false;
  std::string world = std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world";
  app.add_option("--seconds", seconds, "measured seconds per phase")->capture_default_str();
  app.add_option("--priority", priority, "SCHED_FIFO priority of the RT loop (0 = none; needs CAP_SYS_NICE)")->capture_default_str();
  app.add_option("--world", world, "world file")->capture_default_str();
  app.add_option("--max-p50-ms", max_p50_ms, "fail when either phase's median latency exceeds this")->capture_default_str();
  app.add_option("--max-p99-ms", max_p99_ms, "fail when either phase's p99 latency exceeds this")->capture_default_str();
  app.add_flag("--json", json, "print the figures as one JSON object on stdout (the table goes to stderr)");
  CLI11_PARSE(app, argc, argv);
  FILE* table = json ? stderr : stdout;
  std::fprintf(table, "robot latency bench: %.0f s per phase, RT priority %d\n", seconds, priority);
  const Phase idle = run_phase(world, seconds, priority, false);
  const Phase loaded = run_phase(world, seconds, priority, true);
  std::fprintf(table, "\n%-8s %8s %10s %10s %10s %12s %12s %8s\n", "phase", "scans", "lat p50 ms", "lat p99 ms", "lat max ms",
               "period p99us", "jitter maxus", "misses");
  for (const auto* p : {&idle, &loaded}) {
    std::fprintf(table, "%-8s %8zu %10.2f %10.2f %10.2f %12.0f %12.0f %8llu\n", p == &idle ? "idle" : "loaded",
                 p->latency_ms.size(), percentile(p->latency_ms, 0.5), percentile(p->latency_ms, 0.99),
                 percentile(p->latency_ms, 1.0), static_cast<double>(p->rt.period_p99_us),
                 static_cast<double>(p->rt.jitter_max_us), static_cast<unsigned long long>(p->rt.misses));
  }
  const double p99_ratio = percentile(loaded.latency_ms, 0.99) / std::max(1e-9, percentile(idle.latency_ms, 0.99));
  const double jitter_ratio =
      static_cast<double>(loaded.rt.jitter_max_us) / std::max(1.0, static_cast<double>(idle.rt.jitter_max_us));
  std::fprintf(table, "\n%-8s %16s %16s %18s %18s\n", "phase", "line p50 ms", "line p99 ms", "emulator late p99", "scan work p99/max us");
  for (const auto* p : {&idle, &loaded}) {
    std::fprintf(table, "%-8s %16.2f %16.2f %18.2f %11.0f/%.0f\n", p == &idle ? "idle" : "loaded", percentile(p->line_latency_ms, 0.5),
                 percentile(p->line_latency_ms, 0.99), percentile(p->emulator_late_ms, 0.99),
                 static_cast<double>(p->rt.scan_work_p99_us), static_cast<double>(p->rt.scan_work_max_us));
  }
  std::fprintf(table, "ratio loaded/idle: latency p99 %.2f, jitter max %.2f\n", p99_ratio, jitter_ratio);
  std::string failure;
  if (idle.latency_ms.size() < 10 || loaded.latency_ms.size() < 10) {
    failure = "too few scans matched (" + std::to_string(idle.latency_ms.size()) + ", " +
              std::to_string(loaded.latency_ms.size()) + ")";
  } else if (percentile(idle.latency_ms, 0.5) > max_p50_ms || percentile(loaded.latency_ms, 0.5) > max_p50_ms) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "p50 latency %.2f ms idle / %.2f ms loaded exceeds %.2f ms",
                  percentile(idle.latency_ms, 0.5), percentile(loaded.latency_ms, 0.5), max_p50_ms);
    failure = buf;
  } else if (percentile(idle.latency_ms, 0.99) > max_p99_ms || percentile(loaded.latency_ms, 0.99) > max_p99_ms) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "p99 latency %.2f ms idle / %.2f ms loaded exceeds %.2f ms",
                  percentile(idle.latency_ms, 0.99), percentile(loaded.latency_ms, 0.99), max_p99_ms);
    failure = buf;
  }
  if (json) {
    const nlohmann::json j = {{"bench", "robot_latency"},
                              {"seconds_per_phase", seconds},
                              {"priority", priority},
                              {"max_p50_ms", max_p50_ms},
                              {"max_p99_ms", max_p99_ms},
                              {"idle", phase_json(idle)},
                              {"loaded", phase_json(loaded)},
                              {"ratio_loaded_idle", {{"latency_p99", p99_ratio}, {"jitter_max", jitter_ratio}}},
                              {"pass", failure.empty()},
                              {"failure", failure}};
    std::printf("%s\n", j.dump(2).c_str());
  }
  if (!failure.empty()) {
    std::fprintf(stderr, "cairn-bench-robot-latency: FAIL: %s\n", failure.c_str());
    return 1;
  }
  return 0;
}
