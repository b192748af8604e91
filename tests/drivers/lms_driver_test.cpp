// The LMS2xx driver against the byte-exact emulator over a pty and over TCP: power-on
// to streaming from every start baud, scans equal to the world's ray casts, every
// injected fault survived and counted, baud-aware timestamps, and no SIGPIPE when a TCP
// peer goes away.
#include "drivers/sick/lms_driver.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

#include "hil/lms2xx/lms_server.hpp"
#include "tests/support/pty_baud.hpp"
#include "tests/support/timing.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;

const char* kWorld =
    "box 0 0 20 20\n"
    "pole 9 6 0.05\npole 12 9 0.05\npole 6 12 0.05\n"
    "circle 14 14 0.5\nbox 3 3 1 1\n";
const Pose2 kSensor{8.0, 8.0, 0.3};

// The pty link exercises baud detection and switching; where a pty cannot carry 500 kBd
// (under qemu-user) those cases are skipped and the content checks run over TCP.
#define SKIP_UNLESS_PTY_CARRIES_500K()                 \
  do {                                                 \
    std::string why;                                   \
    if (!testing::pty_carries_500k(&why)) GTEST_SKIP() << why; \
  } while (0)

struct Collector : lms::ScanSink {
  std::mutex m;
  std::vector<lms::LmsScan> scans;
  void on_scan(const lms::LmsScan& s) override {
    std::lock_guard l(m);
    scans.push_back(s);
  }
  std::size_t count() {
    std::lock_guard l(m);
    return scans.size();
  }
};

class Bench {
 public:
  explicit Bench(hil::LmsServer::Link link, std::uint32_t target = 500000)
      : world_(hil::World::parse(kWorld, "test")),
        server_(link, cfg(link, target), &world_, [](Nanos) { return kSensor; }) {
    server_.start();
    std::string err;
    stream_ = serial::open_stream(server_.uri(), link == hil::LmsServer::Link::kTcp ? target : 9600, &err);
    if (!stream_) throw std::runtime_error(err);
    lms::LmsDriverConfig dc;
    dc.target_baud = target;
    dc.resolution_centideg = 50;
    driver_ = std::make_unique<lms::LmsDriver>(stream_.get(), &MonotonicClock::instance(), dc, &sink_);
  }
  ~Bench() {
    stop_io();
    server_.stop();
  }
  static hil::LmsDeviceConfig cfg(hil::LmsServer::Link link = hil::LmsServer::Link::kPty, std::uint32_t target = 500000) {
    hil::LmsDeviceConfig c;
    c.boot_time_s = 0.2;
    c.range_noise_m = 0.005;
    // Behind a serial device server (TCP) the laser is set permanently to the server's rate.
    if (link == hil::LmsServer::Link::kTcp) c.power_on_baud = target;
    return c;
  }
  void start_io() {
    running_ = true;
    io_ = std::thread([this] {
      while (running_) {
        std::lock_guard l(driver_mutex_);
        driver_->step();
      }
    });
  }
  void stop_io() {
    running_ = false;
    if (io_.joinable()) io_.join();
  }
  /// Waits until the driver streams and `n` more scans arrived; returns seconds taken or -1.
  double wait_streaming(std::size_t n, std::chrono::milliseconds timeout) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t base = sink_.count();
    while (std::chrono::steady_clock::now() - t0 < timeout) {
      if (state() == lms::DriverState::kStreaming && sink_.count() >= base + n) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      }
      std::this_thread::sleep_for(5ms);
    }
    return -1;
  }
  lms::DriverState state() {
    std::lock_guard l(driver_mutex_);
    return driver_->state();
  }
  lms::LmsCounters counters() {
    std::lock_guard l(driver_mutex_);
    return driver_->counters();
  }
  std::string reason() {
    std::lock_guard l(driver_mutex_);
    return driver_->reason();
  }
  hil::World world_;
  hil::LmsServer server_;
  std::unique_ptr<serial::ByteStream> stream_;
  Collector sink_;
  std::unique_ptr<lms::LmsDriver> driver_;
  std::mutex driver_mutex_;
  std::thread io_;
  std::atomic<bool> running_{false};
};

// Received scans identified by content (SentScan::fingerprint): for each of the sink's
// scans from `first` on, the emulator's scan it is (nullptr if none, or if two sent scans
// share the fingerprint). The copies are taken under the device's lock.
struct Identified {
  std::vector<hil::SentScan> sent;        // the emulator's record, oldest first
  std::vector<const hil::SentScan*> of;   // per received scan
  std::vector<lms::LmsScan> got;
  /// Sent indices between the first and the last identified scan that never arrived.
  std::vector<std::uint32_t> missing() const {
    std::vector<std::uint32_t> idx;
    for (const auto* s : of) {
      if (s) idx.push_back(s->index);
    }
    std::vector<std::uint32_t> out;
    for (std::size_t i = 1; i < idx.size(); ++i) {
      for (std::uint32_t k = idx[i - 1] + 1; k < idx[i]; ++k) out.push_back(k);
    }
    return out;
  }
  bool in_order() const {
    std::uint32_t last = 0;
    for (const auto* s : of) {
      if (!s) return false;
      if (s->index <= last) return false;
      last = s->index;
    }
    return true;
  }
};
Identified identify(Bench& b, std::size_t first) {
  Identified r;
  {
    std::lock_guard l(b.sink_.m);
    r.got.assign(b.sink_.scans.begin() + static_cast<long>(std::min(first, b.sink_.scans.size())), b.sink_.scans.end());
  }
  b.server_.with_device([&](hil::LmsDevice& d) {
    r.sent.assign(d.sent_scans().begin(), d.sent_scans().end());
    return 0;
  });
  for (const auto& g : r.got) {
    const std::uint64_t fp = hil::scan_fingerprint(g.count, g.range_mm.data(), g.flags.data());
    const hil::SentScan* match = nullptr;
    int matches = 0;
    for (const auto& s : r.sent) {
      if (s.fingerprint == fp) {
        match = &s;
        ++matches;
      }
    }
    r.of.push_back(matches == 1 ? match : nullptr);
  }
  return r;
}

TEST(LmsDriver, PowerOnToStreamingFromEveryStartBaud) {
  SKIP_UNLESS_PTY_CARRIES_500K();
  for (std::uint32_t start : {9600u, 19200u, 38400u, 500000u}) {
    SCOPED_TRACE(start);
    Bench b(hil::LmsServer::Link::kPty);
    std::this_thread::sleep_for(300ms);  // booted: the power-on telegram went out at 9600
    b.server_.force_baud(start);         // a device left at another permanent rate
    b.start_io();
    const double t = b.wait_streaming(5, 5s);
    ASSERT_GT(t, 0) << b.reason();
    EXPECT_LT(t, 3.0 * testing::timing_slack()) << "streaming took " << t << " s";
    EXPECT_EQ(b.stream_->baud(), 500000u);
    EXPECT_STREQ(b.driver_->device_type(), "LMS291;S05          ");
    std::printf("start %6u baud: streaming after %.3f s\n", start, t);
  }
}

TEST(LmsDriver, ScansEqualTheWorldsRayCasts) {
  std::string why;
  const bool pty = testing::pty_carries_500k(&why);
  Bench b(pty ? hil::LmsServer::Link::kPty : hil::LmsServer::Link::kTcp);
  if (!pty) std::printf("over TCP: %s\n", why.c_str());
  b.start_io();
  ASSERT_GT(b.wait_streaming(10, 5s), 0) << b.reason();
  std::lock_guard l(b.sink_.m);
  const lms::LmsScan& s = b.sink_.scans.back();
  ASSERT_EQ(s.count, 361);
  int reflective_seen = 0, compared = 0;
  for (int i = 0; i < s.count; ++i) {
    const double a = kSensor.theta + s.angle_min + i * s.angle_increment;
    const hil::RayHit h = b.world_.cast(kSensor.translation(), a, 30.0);
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

TEST(LmsDriver, EveryInjectedFaultIsSurvivedCountedAndRecovered) {
  SKIP_UNLESS_PTY_CARRIES_500K();
  Bench b(hil::LmsServer::Link::kPty);
  b.start_io();
  ASSERT_GT(b.wait_streaming(5, 5s), 0) << b.reason();

  // Each fault's window of received scans starts with the last scan before it, so a scan
  // lost right after the injection is a gap inside the window.
  auto window_start = [&] { return b.sink_.count() - 1; };
  // Garbage between telegrams: the driver resynchronises and loses no scan.
  std::size_t from = window_start();
  const auto garbage_crc = b.counters().crc_errors;
  b.server_.inject_garbage(300);
  EXPECT_GT(b.wait_streaming(5, 2s), 0) << "after garbage: " << b.reason();
  EXPECT_GE(b.counters().resyncs, 1u);
  Identified id = identify(b, from);
  EXPECT_TRUE(id.in_order()) << "a scan that is none the emulator sent, or out of order";
  EXPECT_TRUE(id.missing().empty()) << id.missing().size() << " scan(s) lost to garbage between telegrams";
  EXPECT_EQ(b.counters().crc_errors, garbage_crc) << "garbage outside telegrams is no CRC error";

  // One telegram with a flipped CRC byte: exactly that scan is lost, counted once.
  from = window_start();
  const auto crc0 = b.counters().crc_errors;
  b.server_.corrupt_next_crc();
  EXPECT_GT(b.wait_streaming(5, 2s), 0) << "after a flipped CRC: " << b.reason();
  EXPECT_EQ(b.counters().crc_errors, crc0 + 1);
  id = identify(b, from);
  EXPECT_TRUE(id.in_order());
  EXPECT_EQ(id.missing().size(), 1u) << "the corrupted telegram, and only it";

  // One telegram 20 bytes short: its LEN runs into the next telegram, so its CRC fails
  // (counted once); the parser rescans from the byte after the bad STX and finds the next
  // telegram intact. Exactly that scan is lost.
  from = window_start();
  const auto crc1 = b.counters().crc_errors;
  b.server_.drop_bytes(20);
  EXPECT_GT(b.wait_streaming(5, 2s), 0) << "after dropped bytes: " << b.reason();
  EXPECT_EQ(b.counters().crc_errors, crc1 + 1);
  id = identify(b, from);
  EXPECT_TRUE(id.in_order());
  EXPECT_EQ(id.missing().size(), 1u) << "the shortened telegram, and only it";

  // Unplugged for a second: the driver notices, searches, and streams again once replugged.
  const auto timeouts = b.counters().timeouts;
  b.server_.unplug(true);
  std::this_thread::sleep_for(1s);
  EXPECT_NE(b.state(), lms::DriverState::kStreaming);
  EXPECT_GT(b.counters().timeouts, timeouts);
  b.server_.unplug(false);
  double t = b.wait_streaming(3, 5s);
  EXPECT_GT(t, 0) << "after unplug: " << b.reason();
  EXPECT_LT(t, 3.0 * testing::timing_slack());

  // Power cycle: back at 9600 in idle mode; the driver reconfigures within 3 s of the power-on telegram.
  b.server_.power_cycle();
  t = b.wait_streaming(3, 6s);
  EXPECT_GT(t, 0) << "after power cycle: " << b.reason();
  EXPECT_LT(t, (3.0 + Bench::cfg().boot_time_s) * testing::timing_slack());
  EXPECT_EQ(b.stream_->baud(), 500000u);

  // The device jumps to another baud rate: garbage, then re-detection.
  b.server_.force_baud(38400);
  t = b.wait_streaming(3, 6s);
  EXPECT_GT(t, 0) << "after a wrong baud: " << b.reason();
  EXPECT_LT(t, 3.0 * testing::timing_slack());
  std::printf("counters: scans %llu, crc %llu, resyncs %llu, timeouts %llu, reconnects %llu, power-on %llu\n",
              static_cast<unsigned long long>(b.counters().scans), static_cast<unsigned long long>(b.counters().crc_errors),
              static_cast<unsigned long long>(b.counters().resyncs), static_cast<unsigned long long>(b.counters().timeouts),
              static_cast<unsigned long long>(b.counters().reconnects),
              static_cast<unsigned long long>(b.counters().power_on_telegrams));
}

TEST(LmsDriver, BaudAwareTimestampsMatchTheEmulatorsLineTimes) {
  SKIP_UNLESS_PTY_CARRIES_500K();
  Bench b(hil::LmsServer::Link::kPty);
  b.start_io();
  ASSERT_GT(b.wait_streaming(100, 10s), 0) << b.reason();
  b.stop_io();
  // Each received scan is matched to the scan the emulator sent by content (fingerprint),
  // not to the sent scan nearest in time: an error of a whole scan period (27 ms) or more
  // cannot hide as a match to the neighbouring scan.
  const Identified id = identify(b, 0);
  ASSERT_GE(id.got.size(), 100u);
  std::vector<double> errors_us;
  std::size_t unmatched = 0;
  for (std::size_t i = 0; i < id.got.size(); ++i) {
    const hil::SentScan* sent = id.of[i];
    if (!sent || sent->tx_start < 0 || sent->last_byte_written < 0) {
      ++unmatched;
      continue;
    }
    // The reference is the first byte's line time as the host can know it: the telegram
    // laid back from the write that carried its last byte. The emulator's own pacing
    // lateness (a user-space thread, up to ms on a busy machine) moves both alike; the
    // ideal time tx_start would charge it to the driver.
    const Nanos line = static_cast<Nanos>(static_cast<double>(sent->bytes) * serial::byte_time_s(500000) * 1e9);
    const Nanos reference = std::max(sent->tx_start, sent->last_byte_written - line);
    errors_us.push_back(std::abs(static_cast<double>(id.got[i].first_byte_time - reference)) / 1e3);
  }
  EXPECT_EQ(unmatched, 0u) << "received scans the emulator has no (unique) record of";
  EXPECT_TRUE(id.in_order());
  EXPECT_TRUE(id.missing().empty()) << id.missing().size() << " scans lost while streaming without faults";
  ASSERT_FALSE(errors_us.empty());
  std::sort(errors_us.begin(), errors_us.end());
  const double p50 = errors_us[errors_us.size() / 2], p99 = errors_us[errors_us.size() * 99 / 100];
  std::printf("first-byte time error vs the emulator's line time (%zu scans at 500 kBd): p50 %.0f us, p99 %.0f us\n",
              errors_us.size(), p50, p99);
  // A 0.5° beam takes 18.5 µs; a user-space pty bench paces in 200 µs steps and is read by
  // another process, so we hold it to 1 ms (docs/lms2xx.md explains the bound).
  EXPECT_LT(p50, 1000.0 * testing::timing_slack());
  EXPECT_LT(p99, 2000.0 * testing::timing_slack());
}

TEST(LmsDriver, StreamsOverTcpAtAFixedBaud) {
  Bench b(hil::LmsServer::Link::kTcp, 500000);  // the laser wakes at the device server's 500 kBd
  b.start_io();
  const double t = b.wait_streaming(10, 5s);
  ASSERT_GT(t, 0) << b.reason();
  EXPECT_LT(t, 3.0 * testing::timing_slack());
}

// Neither end of a TCP link dies of SIGPIPE when the other goes away (a library user need
// not ignore the signal): the driver's write reports the link closed, and the emulator,
// still streaming to a client that left, carries on.
TEST(LmsDriver, TcpPeerGoneIsClosedNotSigpipe) {
  {
    Bench b(hil::LmsServer::Link::kTcp, 500000);
    b.start_io();
    ASSERT_GT(b.wait_streaming(5, 5s), 0) << b.reason();
    b.stop_io();
    b.stream_.reset();  // the client leaves while the laser streams
    std::this_thread::sleep_for(300ms);
  }
  const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(listener, 1), 0);
  ASSERT_EQ(::getsockname(listener, reinterpret_cast<sockaddr*>(&a), &len), 0);
  std::string err;
  auto stream = serial::open_stream("tcp:127.0.0.1:" + std::to_string(ntohs(a.sin_port)), 500000, &err);
  ASSERT_TRUE(stream) << err;
  ::close(::accept(listener, nullptr, nullptr));  // the device server drops the connection
  ::close(listener);
  const std::uint8_t bytes[64] = {};
  serial::IoResult r;
  for (int i = 0; i < 100 && r.status != serial::IoResult::Status::kClosed; ++i) r = stream->write(bytes, 100 * kNanosPerMilli);
  EXPECT_EQ(r.status, serial::IoResult::Status::kClosed);
}

TEST(LmsDriver, MissingPortsGiveClearErrors) {
  std::string err;
  EXPECT_EQ(serial::open_stream("tty:/dev/does-not-exist", 9600, &err), nullptr);
  EXPECT_NE(err.find("tty:/dev/does-not-exist: cannot open"), std::string::npos) << err;
  EXPECT_EQ(serial::open_stream("serial:/dev/ttyUSB99", 9600, &err), nullptr);
  EXPECT_NE(err.find("serial:/dev/ttyUSB99"), std::string::npos) << err;
  EXPECT_NE(err.find("libserialport sees"), std::string::npos) << err;
  EXPECT_EQ(serial::open_stream("tcp:127.0.0.1:1", 9600, &err), nullptr);
  EXPECT_NE(err.find("cannot connect"), std::string::npos) << err;
  EXPECT_EQ(serial::open_stream("bogus", 9600, &err), nullptr);
  EXPECT_NE(err.find("expected serial:DEVICE"), std::string::npos) << err;
  EXPECT_DOUBLE_EQ(serial::byte_time_s(500000), 20e-6);
  EXPECT_EQ(serial::first_byte_time(1'000'000'000, 732, 38400), 1'000'000'000 - 190'625'000);
}

}  // namespace
}  // namespace cairn
