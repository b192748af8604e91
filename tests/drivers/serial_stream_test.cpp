// The serial: backend (SerialPortStream) without a UART: libserialport cannot open a pty
// here, so this binary links a stand-in for the libserialport calls the backend makes
// (its definitions take precedence over the shared library's at link time). The stand-in
// hands out one end of a socketpair as the port's descriptor and keeps libserialport's
// documented semantics where they matter: sp_wait / sp_blocking_write with timeout 0 mean
// "wait forever", and sp_wait mallocs its pollfd array on every call (libserialport
// 0.1.1 serialport.c). What this cannot test: termios on a real UART (baud, 8N1), a USB
// adapter's unplug (EIO), and libserialport's own port enumeration; the VM bench does.
#include <fcntl.h>
#include <libserialport.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "drivers/serial/byte_stream.hpp"
#include "drivers/serial/fd_stream.hpp"
#include "tests/support/timing.hpp"
#ifdef CAIRN_COUNT_ALLOCS
#include "tests/support/alloc_counter.hpp"
#endif

// ------------------------------------------------------------- the libserialport stand-in

struct sp_port {
  int fd = -1;
};

namespace {
struct Fake {
  int port_fd = -1;          // what sp_get_port_handle hands out
  int waits_forever = 0;     // sp_wait / sp_blocking_write asked with timeout 0
  int library_io_calls = 0;  // sp_wait, sp_blocking_*, sp_nonblocking_read, sp_input_waiting
  int lookups = 0;           // sp_get_port_by_name (allocates the port's record)
  int open_errno = 0;        // sp_open fails with this errno (SP_ERR_FAIL) when set
};
Fake g_fake;
sp_event_set g_events{};
int g_event_fd = -1;
char g_name[] = "fake0";
}  // namespace

extern "C" {
sp_return sp_get_port_by_name(const char* name, sp_port** port) {
  if (std::strcmp(name, g_name) != 0 || g_fake.port_fd < 0) return SP_ERR_ARG;
  ++g_fake.lookups;
  *port = new sp_port{g_fake.port_fd};  // libserialport mallocs the record and its strings
  return SP_OK;
}
void sp_free_port(sp_port* port) { delete port; }
sp_return sp_list_ports(sp_port*** list) {
  static sp_port* none[] = {nullptr};
  *list = none;
  return SP_OK;
}
void sp_free_port_list(sp_port**) {}
sp_return sp_open(sp_port*, sp_mode) { return g_fake.open_errno ? SP_ERR_FAIL : SP_OK; }
int sp_last_error_code(void) { return g_fake.open_errno; }
sp_return sp_close(sp_port*) { return SP_OK; }
char* sp_get_port_name(const sp_port*) { return g_name; }
sp_return sp_get_port_handle(const sp_port* port, void* result) {
  *static_cast<int*>(result) = port->fd;
  return SP_OK;
}
sp_return sp_set_baudrate(sp_port*, int) { return SP_OK; }
sp_return sp_set_bits(sp_port*, int) { return SP_OK; }
sp_return sp_set_parity(sp_port*, sp_parity) { return SP_OK; }
sp_return sp_set_stopbits(sp_port*, int) { return SP_OK; }
sp_return sp_set_flowcontrol(sp_port*, sp_flowcontrol) { return SP_OK; }
sp_return sp_flush(sp_port*, sp_buffer) { return SP_OK; }
char* sp_last_error_message(void) { return nullptr; }
void sp_free_error_message(char*) {}
sp_return sp_new_event_set(sp_event_set** set) {
  *set = &g_events;
  return SP_OK;
}
sp_return sp_add_port_events(sp_event_set*, const sp_port* port, sp_event) {
  g_event_fd = port->fd;
  return SP_OK;
}
void sp_free_event_set(sp_event_set*) {}
sp_return sp_input_waiting(sp_port*) {
  ++g_fake.library_io_calls;
  return SP_OK;  // 0 bytes: the caller then waits
}
sp_return sp_wait(sp_event_set*, unsigned int timeout_ms) {
  ++g_fake.library_io_calls;
  void* volatile pollfds = std::malloc(sizeof(pollfd));  // as libserialport does, every call (volatile: not elided)
  std::free(pollfds);
  if (timeout_ms == 0) {
    ++g_fake.waits_forever;  // libserialport would block until data arrives: fail instead of hanging
    return SP_OK;
  }
  pollfd p{g_event_fd, POLLIN, 0};
  poll(&p, 1, static_cast<int>(timeout_ms));
  return SP_OK;
}
sp_return sp_nonblocking_read(sp_port* port, void* buf, size_t count) {
  ++g_fake.library_io_calls;
  const ssize_t n = ::read(port->fd, buf, count);
  return static_cast<sp_return>(n < 0 ? 0 : n);
}
sp_return sp_blocking_write(sp_port* port, const void* buf, size_t count, unsigned int timeout_ms) {
  ++g_fake.library_io_calls;
  if (timeout_ms == 0) ++g_fake.waits_forever;  // "wait forever" until all is written
  const ssize_t n = ::write(port->fd, buf, count);
  return static_cast<sp_return>(n < 0 ? 0 : n);
}
}  // extern "C"

// ------------------------------------------------------------------------------ tests

namespace cairn::serial {
namespace {

class SerialPortStreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    g_fake = {};
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM, 0, sv_), 0);
    const int small = 4096;  // a small line buffer, so a write can fill it
    setsockopt(sv_[0], SOL_SOCKET, SO_SNDBUF, &small, sizeof small);
    setsockopt(sv_[1], SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    fcntl(sv_[1], F_SETFL, fcntl(sv_[1], F_GETFL) | O_NONBLOCK);
    fcntl(sv_[0], F_SETFL, fcntl(sv_[0], F_GETFL) | O_NONBLOCK);  // as sp_open leaves a port
    g_fake.port_fd = sv_[0];
    std::string err;
    stream_ = open_stream("serial:fake0", 115200, &err);
    ASSERT_TRUE(stream_) << err;
  }
  void TearDown() override {
    stream_.reset();
    ::close(sv_[0]);
    ::close(sv_[1]);
  }
  int sv_[2] = {-1, -1};  // [0] the port's descriptor, [1] the device on the other end
  std::unique_ptr<ByteStream> stream_;
};

double seconds_since(Nanos t0) { return nanos_to_seconds(MonotonicClock::instance().now() - t0); }

TEST_F(SerialPortStreamTest, ZeroTimeoutReadDoesNotWait) {
  std::uint8_t buf[64];
  const Nanos t0 = MonotonicClock::instance().now();
  const IoResult r = stream_->read(buf, 0);
  EXPECT_EQ(r.status, IoResult::Status::kTimeout);
  EXPECT_EQ(r.bytes, 0u);
  EXPECT_EQ(g_fake.waits_forever, 0) << "a zero timeout reached libserialport as 'wait forever'";
  EXPECT_LT(seconds_since(t0), 0.005 * testing::timing_slack());
  // Zero means "do not wait", not "do not read": what is there is returned.
  const std::uint8_t hello[] = {'h', 'i'};
  ASSERT_EQ(::write(sv_[1], hello, 2), 2);
  const IoResult got = stream_->read(buf, 0);
  ASSERT_EQ(got.status, IoResult::Status::kOk);
  EXPECT_EQ(got.bytes, 2u);
  EXPECT_EQ(buf[1], 'i');
}

TEST_F(SerialPortStreamTest, ZeroTimeoutWriteDoesNotWaitWhenTheLineIsFull) {
  std::vector<std::uint8_t> chunk(1024, 0x55);
  bool saw_timeout = false;
  for (int i = 0; i < 2000 && !saw_timeout; ++i) {  // the other end never reads: the buffer fills
    const Nanos t0 = MonotonicClock::instance().now();
    const IoResult r = stream_->write(chunk, 0);
    ASSERT_LT(seconds_since(t0), 0.005 * testing::timing_slack()) << "write " << i << " waited";
    saw_timeout = r.status == IoResult::Status::kTimeout;
    if (saw_timeout) {
      EXPECT_LT(r.bytes, chunk.size());
    }
  }
  EXPECT_TRUE(saw_timeout) << "the line never filled";
  EXPECT_EQ(g_fake.waits_forever, 0) << "a zero timeout reached libserialport as 'wait forever'";
}

TEST_F(SerialPortStreamTest, ReadTimeoutIsHonoured) {
  std::uint8_t buf[8];
  const Nanos t0 = MonotonicClock::instance().now();
  EXPECT_EQ(stream_->read(buf, 30 * kNanosPerMilli).status, IoResult::Status::kTimeout);
  const double waited = seconds_since(t0);
  EXPECT_GE(waited, 0.029);
  EXPECT_LT(waited, 0.030 + 0.050 * testing::timing_slack());
}

// Streaming works on the descriptor: no libserialport I/O call, so no allocation either.
TEST_F(SerialPortStreamTest, StreamingUsesTheDescriptorAndAllocatesNothing) {
  std::uint8_t out[32], in[64];
  for (std::size_t i = 0; i < sizeof out; ++i) out[i] = static_cast<std::uint8_t>(i * 7);
  std::size_t echoed = 0;
#ifdef CAIRN_COUNT_ALLOCS
  cairn::testing::start_counting_allocations();
#endif
  for (int round = 0; round < 200; ++round) {
    if (stream_->write(out, 100 * kNanosPerMilli).status != IoResult::Status::kOk) break;
    std::uint8_t dev[64];
    const ssize_t n = ::read(sv_[1], dev, sizeof dev);  // the device echoes what it got
    if (n > 0 && ::write(sv_[1], dev, static_cast<std::size_t>(n)) != n) break;
    std::size_t got = 0;
    while (got < sizeof out) {
      const IoResult r = stream_->read({in + got, sizeof in - got}, 100 * kNanosPerMilli);
      if (!r.ok()) break;
      got += r.bytes;
    }
    if (got == sizeof out && std::memcmp(in, out, sizeof out) == 0) ++echoed;
  }
#ifdef CAIRN_COUNT_ALLOCS
  const std::uint64_t allocations = cairn::testing::stop_counting_allocations();
  EXPECT_EQ(allocations, 0u) << "the serial: path allocated while streaming";
#endif
  EXPECT_EQ(echoed, 200u);
  EXPECT_EQ(g_fake.library_io_calls, 0) << "streaming went through libserialport's I/O calls";
}

// A reopen (the laser's I/O thread, after an unplug) reuses the port record found at open:
// no lookup, no allocation, no message built; and the link streams again afterwards.
TEST_F(SerialPortStreamTest, ReopenReusesThePortAndAllocatesNothing) {
  ASSERT_EQ(g_fake.lookups, 1);
  IoError results[3];
#ifdef CAIRN_COUNT_ALLOCS
  cairn::testing::start_counting_allocations();
#endif
  for (IoError& r : results) r = stream_->reopen();
#ifdef CAIRN_COUNT_ALLOCS
  const std::uint64_t allocations = cairn::testing::stop_counting_allocations();
  EXPECT_EQ(allocations, 0u) << "the serial: reopen allocated";
#endif
  for (const IoError& r : results) EXPECT_TRUE(r.ok()) << io_errc_text(r.code);
  EXPECT_EQ(g_fake.lookups, 1) << "each reopen looked the port up again (sp_get_port_by_name allocates)";
  const std::uint8_t hello[] = {'o', 'k'};
  ASSERT_EQ(::write(sv_[1], hello, 2), 2);
  std::uint8_t buf[8];
  const IoResult got = stream_->read(buf, 100 * kNanosPerMilli);
  ASSERT_EQ(got.status, IoResult::Status::kOk);
  EXPECT_EQ(got.bytes, 2u);
}

// A reopen that fails (the adapter unplugged: ENOENT) says so with the code, not ok with
// a dead descriptor; reads then report the link closed, and the next good reopen streams.
TEST_F(SerialPortStreamTest, AFailedReopenIsAnErrorAndTheLinkStaysClosed) {
  g_fake.open_errno = ENOENT;
  const IoError e = stream_->reopen();
  EXPECT_EQ(e.code, IoErrc::kNotFound) << io_errc_text(e.code);
  EXPECT_EQ(e.sys, ENOENT);
  std::uint8_t buf[8];
  EXPECT_EQ(stream_->read(buf, 0).status, IoResult::Status::kClosed);
  g_fake.open_errno = 0;
  EXPECT_TRUE(stream_->reopen().ok());
  const std::uint8_t hello[] = {'o', 'k'};
  ASSERT_EQ(::write(sv_[1], hello, 2), 2);
  EXPECT_EQ(stream_->read(buf, 100 * kNanosPerMilli).status, IoResult::Status::kOk);
}

}  // namespace
}  // namespace cairn::serial
