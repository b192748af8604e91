// The LMS2xx driver's logic on simulated time: the production LmsDriver against the
// byte-exact emulator behind a simulated serial line (hil/lms2xx/sim_lms_link), which
// carries the device's bytes one at a time at its baud rate. No threads, no sleeps: the
// power-on search from every start baud (streaming within 3 s), scans equal to the world's
// ray casts (interlaced ones at their own angles), every wire fault counted exactly, and
// the baud-aware timestamps checked to well under a beam period. The same driver over a real
// pty and TCP, in real time, is lms_driver_test (the transports).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <vector>

#include "drivers/sick/lms_driver.hpp"
#include "hil/lms2xx/sim_lms_link.hpp"

namespace cairn {
namespace {

const char* kWorld =
    "box 0 0 20 20\n"
    "pole 9 6 0.05\npole 12 9 0.05\npole 6 12 0.05\n"
    "circle 14 14 0.5\nbox 3 3 1 1\n";
const Pose2 kSensor{8.0, 8.0, 0.3};

struct Collector : lms::ScanSink {
  std::vector<lms::LmsScan> scans;
  void on_scan(const lms::LmsScan& s) override { scans.push_back(s); }
};

struct SimBench {
  explicit SimBench(bool interlaced = false)
      : world(hil::World::parse(kWorld, "test")), link(device_config(interlaced), &world, [](Nanos) { return kSensor; }),
        driver(&link, &link.clock(), driver_config(), &sink) {}
  static hil::LmsDeviceConfig device_config(bool interlaced = false) {
    hil::LmsDeviceConfig c;
    c.interlaced = interlaced;
    c.boot_time_s = 0.2;
    c.range_noise_m = 0.005;
    return c;
  }
  static lms::LmsDriverConfig driver_config() {
    lms::LmsDriverConfig c;
    c.target_baud = 500000;
    c.resolution_centideg = 50;
    return c;
  }
  Nanos now() { return link.clock().now(); }
  /// Steps the driver until it streams and `n` more scans arrived; simulated seconds, or -1.
  double until_streaming(std::size_t n, double timeout_s) {
    const Nanos t0 = now(), end = t0 + seconds_to_nanos(timeout_s);
    const std::size_t base = sink.scans.size();
    while (now() < end) {
      if (driver.state() == lms::DriverState::kStreaming && sink.scans.size() >= base + n) {
        return nanos_to_seconds(now() - t0);
      }
      driver.step();
    }
    return -1;
  }
  void run_for(double seconds) {
    const Nanos end = now() + seconds_to_nanos(seconds);
    while (now() < end) driver.step();
  }
  /// The emulator's record of the scan a received one is (by content), or nullptr.
  const hil::SentScan* sent_of(const lms::LmsScan& g) {
    const std::uint64_t fp = hil::scan_fingerprint(g.count, g.range_mm.data(), g.flags.data());
    const hil::SentScan* match = nullptr;
    for (const auto& s : link.device().sent_scans()) {
      if (s.fingerprint == fp) {
        if (match) return nullptr;  // ambiguous
        match = &s;
      }
    }
    return match;
  }
  /// Indices of sent scans missing between the received scans from `first` on.
  std::size_t missing_from(std::size_t first) {
    std::size_t missing = 0;
    std::uint32_t last = 0;
    for (std::size_t i = first; i < sink.scans.size(); ++i) {
      const hil::SentScan* s = sent_of(sink.scans[i]);
      EXPECT_NE(s, nullptr) << "received scan " << i << " is none the emulator sent";
      if (!s) continue;
      EXPECT_GT(s->index, last) << "out of order";
      if (last != 0 && s->index > last + 1) missing += s->index - last - 1;
      last = s->index;
    }
    return missing;
  }

  hil::World world;
  hil::SimLmsLink link;
  Collector sink;
  lms::LmsDriver driver;
};

TEST(LmsSim, PowerOnToStreamingFromEveryStartBaud) {
  for (std::uint32_t start : {9600u, 19200u, 38400u, 500000u}) {
    SCOPED_TRACE(start);
    SimBench b;
    b.link.advance_to(b.now() + 300 * kNanosPerMilli);  // booted: the power-on telegram went out at 9600
    b.link.device().force_baud(start);                  // a device left at another permanent rate
    const double t = b.until_streaming(5, 10.0);
    ASSERT_GT(t, 0) << b.driver.reason();
    EXPECT_LT(t, 3.0) << "streaming took " << t << " s (simulated)";
    EXPECT_EQ(b.link.baud(), 500000u);
    EXPECT_STREQ(b.driver.device_type(), "LMS291;S05          ");
    std::printf("start %6u baud: streaming after %.3f s (simulated)\n", start, t);
  }
}

// With bytes arriving when their last bit does, the driver's baud-aware first-byte time is
// exact and its scan stamp (first byte less the sweep) is the emulator's sweep start; the
// bound is a microsecond, far under the 18.5 us beam period the wall-clock bench cannot see.
TEST(LmsSim, TimestampsMatchTheLineToTheMicrosecond) {
  SimBench b;
  ASSERT_GT(b.until_streaming(100, 10.0), 0) << b.driver.reason();
  std::size_t checked = 0;
  double worst_first_us = 0, worst_stamp_us = 0;
  for (const auto& g : b.sink.scans) {
    const hil::SentScan* s = b.sent_of(g);
    if (!s || s->tx_start < 0 || b.driver.counters().scans == 0) continue;
    worst_first_us = std::max(worst_first_us, std::abs(static_cast<double>(g.first_byte_time - s->tx_start)) / 1e3);
    worst_stamp_us = std::max(worst_stamp_us, std::abs(static_cast<double>(g.stamp - s->sweep_start)) / 1e3);
    ++checked;
  }
  ASSERT_GE(checked, 100u);
  std::printf("%zu scans: first-byte time error max %.3f us, sweep-start error max %.3f us (beam period 18.5 us)\n",
              checked, worst_first_us, worst_stamp_us);
  EXPECT_LE(worst_first_us, 1.0);
  EXPECT_LE(worst_stamp_us, 1.0);
}

TEST(LmsSim, EveryWireFaultIsCountedExactlyAndRecovered) {
  SimBench b;
  ASSERT_GT(b.until_streaming(5, 10.0), 0) << b.driver.reason();
  auto& d = b.link.device();

  // Garbage between telegrams: resynchronised, no scan lost, no CRC error.
  std::size_t from = b.sink.scans.size() - 1;
  auto c = b.driver.counters();
  d.inject_garbage(300);
  ASSERT_GT(b.until_streaming(5, 2.0), 0) << b.driver.reason();
  EXPECT_GE(b.driver.counters().resyncs, c.resyncs + 1);
  EXPECT_EQ(b.driver.counters().crc_errors, c.crc_errors);
  EXPECT_EQ(b.missing_from(from), 0u);

  // A flipped CRC byte: exactly that scan lost, one CRC error.
  from = b.sink.scans.size() - 1;
  c = b.driver.counters();
  d.corrupt_next_telegram_crc();
  ASSERT_GT(b.until_streaming(5, 2.0), 0) << b.driver.reason();
  EXPECT_EQ(b.driver.counters().crc_errors, c.crc_errors + 1);
  EXPECT_EQ(b.missing_from(from), 1u);

  // A telegram 20 bytes short: exactly that scan lost, one CRC error.
  from = b.sink.scans.size() - 1;
  c = b.driver.counters();
  d.drop_from_next_telegram(20);
  ASSERT_GT(b.until_streaming(5, 2.0), 0) << b.driver.reason();
  EXPECT_EQ(b.driver.counters().crc_errors, c.crc_errors + 1);
  EXPECT_EQ(b.missing_from(from), 1u);

  // Unplugged for a second: silence is noticed (stream_timeout 0.5 s + two line times),
  // and streaming resumes after the replug.
  c = b.driver.counters();
  b.link.unplug(true);
  b.run_for(1.0);
  EXPECT_NE(b.driver.state(), lms::DriverState::kStreaming);
  EXPECT_EQ(b.driver.counters().timeouts, c.timeouts + 1) << "the silence counted once, then searching";
  b.link.unplug(false);
  double t = b.until_streaming(3, 5.0);
  ASSERT_GT(t, 0) << b.driver.reason();
  EXPECT_LT(t, 3.0);

  // Power cycle: back at 9600, idle (its power-on telegram is garbage at 500 kBd); the
  // driver notices the silence, searches and reconfigures within 3 s of the power-on.
  c = b.driver.counters();
  b.link.power_cycle();
  t = b.until_streaming(3, 6.0);
  ASSERT_GT(t, 0) << b.driver.reason();
  EXPECT_LT(t, 3.0 + SimBench::device_config().boot_time_s);
  EXPECT_EQ(b.link.baud(), 500000u);
  EXPECT_GT(b.driver.counters().reconnects, c.reconnects);

  // The device jumps to another rate: garbage, then re-detection.
  d.force_baud(38400);
  t = b.until_streaming(3, 6.0);
  ASSERT_GT(t, 0) << b.driver.reason();
  EXPECT_LT(t, 3.0);
  EXPECT_EQ(b.link.baud(), 500000u);
}

TEST(LmsSim, ScansEqualTheWorldsRayCasts) {
  SimBench b;
  ASSERT_GT(b.until_streaming(10, 10.0), 0) << b.driver.reason();
  const lms::LmsScan& s = b.sink.scans.back();
  ASSERT_EQ(s.count, 361);
  int reflective_seen = 0, compared = 0;
  for (int i = 0; i < s.count; ++i) {
    const double a = kSensor.theta + s.angle_min + i * s.angle_increment;
    const hil::RayHit h = b.world.cast(kSensor.translation(), a, 30.0);
    if (!h.hit) {
      EXPECT_EQ(s.range_mm[i], 0) << i;
      continue;
    }
    EXPECT_NEAR(s.range_mm[i] / 1000.0, h.range, 5 * 0.005 + 0.001) << "beam " << i;
    EXPECT_EQ(s.flags[i] != 0, h.reflective) << "beam " << i;
    reflective_seen += h.reflective;
    ++compared;
  }
  EXPECT_EQ(compared, 361);
  EXPECT_GT(reflective_seen, 0);
}

// Interlaced output: partial scans 1..3 start 0.25, 0.5, 0.75 deg further round. Each of four
// successive scans must carry its offset and match the world's ray casts at its own angles.
TEST(LmsSim, InterlacedPartialScansCarryTheirAngleOffset) {
  SimBench b(/*interlaced=*/true);
  ASSERT_GT(b.until_streaming(8, 10.0), 0) << b.driver.reason();
  ASSERT_GE(b.sink.scans.size(), 4u);
  std::set<long> offsets_mdeg;
  for (std::size_t k = b.sink.scans.size() - 4; k < b.sink.scans.size(); ++k) {
    const lms::LmsScan& s = b.sink.scans[k];
    ASSERT_EQ(s.count, 361);
    const double offset_deg = s.angle_min * 180.0 / std::numbers::pi + 90.0;
    offsets_mdeg.insert(std::lround(offset_deg * 1000));
    int mismatched = 0;
    for (int i = 0; i < s.count; ++i) {
      const hil::RayHit h = b.world.cast(kSensor.translation(), kSensor.theta + s.angle_min + i * s.angle_increment, 30.0);
      if (h.hit != (s.range_mm[i] != 0) || (h.hit && std::abs(s.range_mm[i] / 1000.0 - h.range) > 5 * 0.005 + 0.001)) ++mismatched;
    }
    EXPECT_EQ(mismatched, 0) << "scan with offset " << offset_deg << " deg";
  }
  EXPECT_EQ(offsets_mdeg, (std::set<long>{0, 250, 500, 750})) << "partial-scan offsets";
}

TEST(LmsSim, TheSameRunGivesTheSameScans) {
  auto run = [] {
    SimBench b;
    b.until_streaming(20, 10.0);
    b.link.device().inject_garbage(100);
    b.until_streaming(10, 2.0);
    std::vector<std::uint64_t> out;
    for (const auto& s : b.sink.scans) {
      out.push_back(hil::scan_fingerprint(s.count, s.range_mm.data(), s.flags.data()));
      out.push_back(static_cast<std::uint64_t>(s.stamp));
    }
    return out;
  };
  const auto a = run(), c = run();
  EXPECT_GE(a.size(), 60u);
  EXPECT_EQ(a, c);
}

}  // namespace
}  // namespace cairn
