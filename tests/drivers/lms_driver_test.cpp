// The LMS2xx driver against the byte-exact emulator over a pty and over TCP, in real
// time: the transports only (termios baud switching on a pty from every start baud, TCP at
// a fixed rate, no SIGPIPE when a TCP peer goes away, clear errors for missing ports). The
// driver's logic (time to streaming, scans equal to the world's ray casts, interlaced
// angles, wire faults counted exactly, timestamps to the microsecond) is tested on
// simulated time in lms_sim_test.
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
// (under qemu-user) those cases are skipped; the content checks are lms_sim_test's.
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

TEST(LmsDriver, PowerOnToStreamingFromEveryStartBaud) {
  SKIP_UNLESS_PTY_CARRIES_500K();
  for (std::uint32_t start : {9600u, 19200u, 38400u, 500000u}) {
    SCOPED_TRACE(start);
    Bench b(hil::LmsServer::Link::kPty);
    std::this_thread::sleep_for(300ms);  // booted: the power-on telegram went out at 9600
    b.server_.force_baud(start);         // a device left at another permanent rate
    b.start_io();
    // A hang guard, not a bound: LmsSim bounds the time to streaming on simulated time.
    const double t = b.wait_streaming(5, 20s);
    ASSERT_GT(t, 0) << b.reason();
    EXPECT_EQ(b.stream_->baud(), 500000u);
    EXPECT_STREQ(b.driver_->device_type(), "LMS291;S05          ");
    std::printf("start %6u baud: streaming after %.3f s\n", start, t);
  }
}

TEST(LmsDriver, StreamsOverTcpAtAFixedBaud) {
  Bench b(hil::LmsServer::Link::kTcp, 500000);  // the laser wakes at the device server's 500 kBd
  b.start_io();
  const double t = b.wait_streaming(10, 20s);
  ASSERT_GT(t, 0) << b.reason();
  // The fixed-baud path (probe the link's own rate, no baud step) has no simulated-time
  // test (SimLmsLink can always set its baud): bounded here.
  EXPECT_LT(t, 3.0 * testing::timing_slack()) << "streaming took " << t << " s";
  std::printf("over TCP: streaming after %.3f s\n", t);
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
