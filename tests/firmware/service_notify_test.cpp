// ServiceNotifier speaks systemd's notify protocol (datagrams on $NOTIFY_SOCKET): READY
// with a status, watchdog pings at half of $WATCHDOG_USEC while the RT cycle count moves,
// none while it stalls, and nothing at all outside systemd.
#include "firmware/service_notify.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

namespace cairn::firmware {
namespace {

class FakeSystemd {
 public:
  FakeSystemd() {
    path_ = "/tmp/cairn-notify-" + std::to_string(getpid()) + ".sock";
    ::unlink(path_.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path_.c_str());
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    ::setenv("WATCHDOG_USEC", "2000000", 1);  // 2 s: pings every 1 s
    ::setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  }
  ~FakeSystemd() {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  std::vector<std::string> received() {
    std::vector<std::string> out;
    char buf[1024];
    ssize_t n;
    while ((n = ::recv(fd_, buf, sizeof buf, 0)) > 0) out.emplace_back(buf, static_cast<std::size_t>(n));
    return out;
  }

 private:
  std::string path_;
  int fd_ = -1;
};

TEST(ServiceNotifier, ReadyThenPingsOnlyWhileTheRtLoopCycles) {
  FakeSystemd systemd;
  ServiceNotifier n;
  ASSERT_TRUE(n.watchdog_enabled());
  EXPECT_EQ(n.watchdog_interval(), 2 * kNanosPerSecond);
  n.ready("robot 7");
  auto got = systemd.received();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], "READY=1\nSTATUS=robot 7");

  // Cycling: one ping per half interval, however often alive() is called.
  std::uint64_t cycles = 0;
  for (Nanos t = 0; t < 5 * kNanosPerSecond; t += 10 * kNanosPerMilli) n.alive(++cycles, t);
  got = systemd.received();
  EXPECT_EQ(got.size(), 5u);  // at 0, 1, 2, 3, 4 s
  for (const auto& m : got) EXPECT_EQ(m, "WATCHDOG=1");

  // Stalled from 4.99 s on: the ping at 5 s still reports the progress since 4 s; after
  // that none, so systemd's watchdog fires and restarts the service.
  for (Nanos t = 5 * kNanosPerSecond; t < 9 * kNanosPerSecond; t += 10 * kNanosPerMilli) n.alive(cycles, t);
  EXPECT_EQ(systemd.received().size(), 1u);
  EXPECT_EQ(n.withheld(), 3u);  // at 6, 7, 8 s

  // Moving again: pings resume.
  n.alive(cycles + 1, 9 * kNanosPerSecond);
  EXPECT_EQ(systemd.received().size(), 1u);
  n.stopping();
  got = systemd.received();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], "STOPPING=1");
}

TEST(ServiceNotifier, SilentOutsideSystemd) {
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  ServiceNotifier n;
  EXPECT_FALSE(n.watchdog_enabled());
  n.ready("x");
  n.alive(1, 0);
  EXPECT_EQ(n.pings(), 0u);
}

}  // namespace
}  // namespace cairn::firmware
