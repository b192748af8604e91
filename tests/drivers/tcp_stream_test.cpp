// The tcp: backend (a serial device server) on loopback: a reopen never holds the laser's
// I/O thread, even when the server does not answer. A listener whose accept queue is full
// drops new SYNs, which is what a device server that hangs looks like to a client.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/clock.hpp"
#include "drivers/serial/fd_stream.hpp"
#ifdef CAIRN_COUNT_ALLOCS
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn {
namespace {

// A loopback listener with an accept queue of one, never accepting until told to.
struct Listener {
  int fd = -1;
  int port = 0;
  std::vector<int> clients;  // connections the test made itself to fill the queue
  Listener() {
    fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);  // drain() must not wait
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 0) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      ADD_FAILURE() << "cannot listen on loopback";
    }
    port = ntohs(a.sin_port);
  }
  ~Listener() {
    for (int c : clients) ::close(c);
    ::close(fd);
  }
  // Fills the accept queue with connections of the test's own, so the next SYN is dropped.
  void fill() {
    for (int i = 0; i < 4; ++i) {
      const int c = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
      sockaddr_in a{};
      a.sin_family = AF_INET;
      a.sin_port = htons(static_cast<std::uint16_t>(port));
      a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      (void)::connect(c, reinterpret_cast<sockaddr*>(&a), sizeof a);
      clients.push_back(c);
    }
    usleep(50000);  // the kernel settles the handshakes
  }
  // Accepts (and drops) everything queued.
  void drain() {
    for (;;) {
      const int c = ::accept4(fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (c < 0) break;
      ::close(c);
    }
  }
};

double ms_since(Nanos t0) { return nanos_to_seconds(MonotonicClock::instance().now() - t0) * 1e3; }

TEST(TcpStream, ReopenNeverWaitsForAServerThatDoesNotAnswerAndConnectsOnceItDoes) {
  Listener server;
  std::string err;
  auto stream = serial::TcpStream::open("127.0.0.1", std::to_string(server.port), 500000, &err);
  ASSERT_TRUE(stream) << err;
  server.drain();
  server.fill();  // from now on the server answers no SYN

  // Each reopen returns at once, the connect going on in the background.
  // And it builds no message: nothing allocates (the laser's I/O thread calls it).
  double slowest_ms = 0;
  IoError last;
#ifdef CAIRN_COUNT_ALLOCS
  cairn::testing::start_counting_allocations();
#endif
  for (int attempts = 0; attempts < 5; ++attempts) {
    const Nanos t0 = MonotonicClock::instance().now();
    last = stream->reopen();
    slowest_ms = std::max(slowest_ms, ms_since(t0));
    if (last.ok()) break;
    usleep(20000);
  }
#ifdef CAIRN_COUNT_ALLOCS
  EXPECT_EQ(cairn::testing::stop_counting_allocations(), 0u) << "a tcp: reopen allocated";
#endif
  EXPECT_FALSE(last.ok()) << "connected to a server whose queue is full";
  EXPECT_LT(slowest_ms, 20.0) << "a reopen waited for the connection";
  EXPECT_EQ(last.code, IoErrc::kConnecting) << io_errc_text(last.code);

  // The server answers again: a later reopen finds the connection (the kernel resends the
  // SYN after about a second).
  server.drain();
  for (int c : server.clients) ::close(c);
  server.clients.clear();
  bool connected = false;
  const Nanos until = MonotonicClock::instance().now() + 10 * kNanosPerSecond;
  while (!connected && MonotonicClock::instance().now() < until) {
    server.drain();
    const Nanos t0 = MonotonicClock::instance().now();
    last = stream->reopen();
    connected = last.ok();
    slowest_ms = std::max(slowest_ms, ms_since(t0));
    usleep(50000);
  }
  EXPECT_TRUE(connected) << io_errc_text(last.code);
  EXPECT_LT(slowest_ms, 20.0);
}

// A connect pending while the server drops SYNs is given up after 2 s and started afresh:
// the kernel's own SYN retries come at 1, 3, 7, 15 ... s, so a server back at 4.5 s would
// otherwise be found only at 7 s.
TEST(TcpStream, APendingConnectIsStartedAfreshSoAServerBackIsFoundQuickly) {
  Listener server;
  std::string err;
  auto stream = serial::TcpStream::open("127.0.0.1", std::to_string(server.port), 500000, &err);
  ASSERT_TRUE(stream) << err;
  server.drain();
  server.fill();
  const Nanos t0 = MonotonicClock::instance().now();
  IoError last;
  while (ms_since(t0) < 4500) {
    last = stream->reopen();
    ASSERT_FALSE(last.ok()) << "connected to a server whose queue is full";
    usleep(50000);
  }
  server.drain();  // the server answers again
  for (int c : server.clients) ::close(c);
  server.clients.clear();
  const Nanos back = MonotonicClock::instance().now();
  bool connected = false;
  while (!connected && ms_since(back) < 5000) {
    server.drain();
    connected = stream->reopen().ok();
    usleep(20000);
  }
  ASSERT_TRUE(connected);
  const double after_ms = ms_since(back);
  std::printf("connected %.0f ms after the server came back\n", after_ms);
  EXPECT_LT(after_ms, 1500.0) << "the connect waited for the kernel's SYN retry at 7 s";
}

TEST(TcpStream, ARefusedConnectionIsAnErrorAtOnce) {
  int port = 0;
  {
    Listener gone;  // a port that was just free: nobody listens there any more
    port = gone.port;
  }
  std::string err;
  const Nanos t0 = MonotonicClock::instance().now();
  EXPECT_FALSE(serial::TcpStream::open("127.0.0.1", std::to_string(port), 500000, &err));
  EXPECT_LT(ms_since(t0), 1000.0);
  EXPECT_NE(err.find("refused"), std::string::npos) << err;
}

}  // namespace
}  // namespace cairn
