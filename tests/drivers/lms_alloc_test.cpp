// The LMS2xx driver's I/O path makes no heap allocation per scan once it streams:
// every allocation on the driver's thread is counted while it streams thousands of scans.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <string>
#include <thread>

#include "drivers/sick/lms_driver.hpp"
#include "hil/lms2xx/lms_server.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/pty_baud.hpp"

namespace cairn {
namespace {

struct CountingSink : lms::ScanSink {
  std::atomic<std::uint64_t> n{0};
  void on_scan(const lms::LmsScan&) override { n.fetch_add(1, std::memory_order_relaxed); }
};

TEST(LmsAllocations, NoneWhileStreaming) {
  const hil::World world = hil::World::parse("box 0 0 20 20\npole 9 6 0.05\n", "t");
  hil::LmsDeviceConfig cfg;
  cfg.boot_time_s = 0.1;
  // Over a pty where it carries 500 kBd; otherwise (qemu-user) over TCP, where the laser is
  // set permanently to the device server's fixed 500 kBd.
  std::string why;
  const bool pty = testing::pty_carries_500k(&why);
  if (!pty) {
    std::printf("over TCP: %s\n", why.c_str());
    cfg.power_on_baud = 500000;
  }
  hil::LmsServer server(pty ? hil::LmsServer::Link::kPty : hil::LmsServer::Link::kTcp, cfg, &world,
                        [](Nanos) { return Pose2{8, 8, 0}; });
  server.start();
  std::string err;
  auto stream = serial::open_stream(server.uri(), pty ? 9600 : 500000, &err);
  ASSERT_TRUE(stream) << err;
  CountingSink sink;
  lms::LmsDriverConfig dc;
  dc.target_baud = 500000;
  dc.resolution_centideg = 100;  // 1°: 75 scans/s
  lms::LmsDriver driver(stream.get(), &MonotonicClock::instance(), dc, &sink);
  std::uint64_t allocations = 0, scans_counted = 0;
  std::thread io([&] {
    // Start-up: until streaming (allocations allowed here).
    const Nanos give_up = MonotonicClock::instance().now() + 5 * kNanosPerSecond;
    while (driver.state() != lms::DriverState::kStreaming && MonotonicClock::instance().now() < give_up) driver.step();
    // Steady state: count.
    const std::uint64_t before = sink.n.load();
    testing::start_counting_allocations();
    const Nanos end = MonotonicClock::instance().now() + 3 * kNanosPerSecond;
    while (MonotonicClock::instance().now() < end) driver.step();
    allocations = testing::stop_counting_allocations();
    scans_counted = sink.n.load() - before;
  });
  io.join();
  server.stop();
  EXPECT_GT(scans_counted, 150u) << driver.reason();  // ~75 Hz for 3 s: the path really ran
  EXPECT_EQ(allocations, 0u) << "the driver allocated " << allocations << " times over " << scans_counted << " scans";
}

void* volatile g_escape;  // keeps the compiler from eliding the allocations below

TEST(LmsAllocations, TheCounterCounts) {  // the test above could not fail if counting were broken
  testing::start_counting_allocations();
  auto* p = new int(3);
  g_escape = p;
  void* q = std::malloc(10);
  g_escape = q;
  std::string s(100, 'x');  // a library allocation (libstdc++)
  g_escape = s.data();
  delete p;
  std::free(q);
  EXPECT_EQ(testing::stop_counting_allocations(), 3u);
}

}  // namespace
}  // namespace cairn
