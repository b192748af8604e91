// cairn-bench-dds: round-trip latency and throughput of Cairn's DDS layer on the
// loopback profile, in the same shape as Cyclone's ddsperf (ping/pong, pub/sub),
// so tests/bench/dds_vs_ddsperf.sh can run both in one go and report ratios.
//
//   cairn-bench-dds pong --domain D --duration S
//   cairn-bench-dds ping --domain D --duration S      -> latency line
//   cairn-bench-dds sub  --domain D --duration S      -> throughput line
//   cairn-bench-dds pub  --domain D --duration S
//   ... --keys DIR   on the secure-loopback profile with a fleet member's keys (role bench:
//                    scripts/fleet-keys.sh add DIR bench NAME; tests/bench/dds_security_cost.sh)
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "common/dds/topics.hpp"

using namespace cairn;
using namespace cairn::dds;

namespace {

using Sample = cairn_PoseCorrection;  // ~140 bytes, like ddsperf "size 128"

Nanos now() { return MonotonicClock::instance().now(); }

int pong(const Participant& pp, double duration) {
  Topic<Sample> ping_t(pp, "bench_ping"), pong_t(pp, "bench_pong");
  Reader<Sample> rd(pp, ping_t, state_qos(1));
  Writer<Sample> wr(pp, pong_t, state_qos(1));
  const Nanos end = now() + seconds_to_nanos(duration);
  while (now() < end) {
    if (!rd.wait(100 * kNanosPerMilli)) continue;
    rd.take([&](const Sample& s, const dds_sample_info_t&) { wr.write(s); });
  }
  return 0;
}

int ping(const Participant& pp, double duration) {
  Topic<Sample> ping_t(pp, "bench_ping"), pong_t(pp, "bench_pong");
  Writer<Sample> wr(pp, ping_t, state_qos(1));
  Reader<Sample> rd(pp, pong_t, state_qos(1));
  if (!wr.wait_for_readers(1, 10 * kNanosPerSecond)) {
    std::fprintf(stderr, "ping: no pong within 10 s\n");
    return 1;
  }
  dds_sleepfor(DDS_MSECS(300));  // let the reverse path match too
  std::vector<double> rtt_us;
  rtt_us.reserve(1 << 20);
  Sample s{};
  s.robot_id = 1;
  const Nanos end = now() + seconds_to_nanos(duration);
  std::uint32_t lost = 0;
  while (now() < end) {
    s.seq++;
    s.stamp_ns = now();
    wr.write(s);
    bool got = false;
    const Nanos give_up = now() + 100 * kNanosPerMilli;
    while (!got && now() < give_up) {
      rd.wait(10 * kNanosPerMilli);
      rd.take([&](const Sample& r, const dds_sample_info_t&) {
        if (r.seq == s.seq) {
          rtt_us.push_back(static_cast<double>(now() - r.stamp_ns) / 1e3);
          got = true;
        }
      });
    }
    if (!got) ++lost;
  }
  if (rtt_us.empty()) {
    std::fprintf(stderr, "ping: no round trips\n");
    return 1;
  }
  std::sort(rtt_us.begin(), rtt_us.end());
  double sum = 0;
  for (double v : rtt_us) sum += v;
  auto pct = [&](double p) { return rtt_us[static_cast<std::size_t>(p * static_cast<double>(rtt_us.size() - 1))]; };
  std::printf("cairn ping size %zu mean %.3fus min %.3fus 50%% %.3fus 90%% %.3fus 99%% %.3fus max %.3fus cnt %zu lost %u\n",
              sizeof(Sample), sum / static_cast<double>(rtt_us.size()), rtt_us.front(), pct(0.5), pct(0.9), pct(0.99),
              rtt_us.back(), rtt_us.size(), lost);
  return 0;
}

int pub(const Participant& pp, double duration) {
  Topic<Sample> t(pp, "bench_data");
  Writer<Sample> wr(pp, t, state_qos(0));  // reliable keep-all: flow-controlled by the reader
  if (!wr.wait_for_readers(1, 10 * kNanosPerSecond)) {
    std::fprintf(stderr, "pub: no sub within 10 s\n");
    return 1;
  }
  Sample s{};
  s.robot_id = 1;
  const Nanos end = now() + seconds_to_nanos(duration);
  while (now() < end) {
    for (int i = 0; i < 100; ++i) {
      s.seq++;
      wr.write(s);
    }
  }
  return 0;
}

int sub(const Participant& pp, double duration) {
  Topic<Sample> t(pp, "bench_data");
  Reader<Sample> rd(pp, t, state_qos(0));
  std::uint64_t count = 0, lost = 0;
  std::uint32_t last_seq = 0;
  Nanos first = 0, last = 0;
  const Nanos end = now() + seconds_to_nanos(duration);
  while (now() < end) {
    if (!rd.wait(100 * kNanosPerMilli)) continue;
    rd.take([&](const Sample& s, const dds_sample_info_t&) {
      if (count == 0) first = now();
      if (last_seq && s.seq > last_seq + 1) lost += s.seq - last_seq - 1;  // an older sample (another run's) is no loss
      last_seq = s.seq;
      ++count;
    });
    last = now();
  }
  const double secs = nanos_to_seconds(last - first);
  if (count < 2 || secs <= 0) {
    std::fprintf(stderr, "sub: no data\n");
    return 1;
  }
  const double rate = static_cast<double>(count) / secs;
  std::printf("cairn sub size %zu total %llu lost %llu rate %.2f kS/s %.2f Mb/s\n", sizeof(Sample),
              static_cast<unsigned long long>(count), static_cast<unsigned long long>(lost), rate / 1e3,
              rate * static_cast<double>(sizeof(Sample)) * 8 / 1e6);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-bench-dds: latency (ping/pong) and throughput (pub/sub) of Cairn's DDS layer on loopback"};
  std::string mode;
  int domain = 0;
  double duration = 5;
  app.add_option("mode", mode, "ping | pong | pub | sub")->required()->check(CLI::IsMember({"ping", "pong", "pub", "sub"}));
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, 230));
  app.add_option("--duration", duration, "seconds");
  std::string keys;
  app.add_option("--keys", keys, "a fleet member's keys directory (role bench): DDS Security on loopback");
  CLI11_PARSE(app, argc, argv);
  try {
    const DdsProfile plain = loopback_profile(static_cast<std::uint32_t>(domain));
    Participant pp(keys.empty() ? plain : secured(plain, keys));
    if (mode == "ping") return ping(pp, duration);
    if (mode == "pong") return pong(pp, duration);
    if (mode == "pub") return pub(pp, duration);
    return sub(pp, duration);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cairn-bench-dds: %s\n", e.what());
    return 1;
  }
}
