// The CAN ports: the user-space bus behaves like a bus (every other node sees every frame,
// in order; own frames only on request; bus-off injected and recovered), and SocketCAN's
// absence on this kernel is a clear error.
#include <gtest/gtest.h>
#include <unistd.h>

#include "drivers/can/can_hub.hpp"
#include "drivers/can/socketcan_port.hpp"

namespace cairn::can {
namespace {

std::string hub_path() { return "/tmp/cairn-can-test-" + std::to_string(getpid()) + ".sock"; }
Nanos soon() { return MonotonicClock::instance().now() + 100 * kNanosPerMilli; }

std::unique_ptr<UcanPort> port(const std::string& path, std::uint16_t id, bool own = false) {
  std::string err;
  auto p = UcanPort::open(path, id, own, &err);
  EXPECT_TRUE(p) << err;
  return p;
}

void settle(const Hub& hub, std::size_t n) {
  for (int i = 0; i < 200 && hub.ports() < n; ++i) usleep(1000);
}

TEST(UserSpaceCan, EveryOtherNodeSeesEveryFrameInOrder) {
  Hub hub(hub_path());
  auto a = port(hub.path(), 1), b = port(hub.path(), 2), c = port(hub.path(), 3, /*own=*/true);
  settle(hub, 3);
  for (std::uint8_t i = 0; i < 50; ++i) {
    Frame f;
    f.id = 0x181;
    f.len = 2;
    f.data[0] = i;
    ASSERT_EQ(a->send(f, soon()), SendResult::kSent);
  }
  for (auto* rx : {b.get(), c.get()}) {
    for (std::uint8_t i = 0; i < 50; ++i) {
      Frame f;
      ASSERT_TRUE(rx->receive(&f, 500 * kNanosPerMilli)) << "frame " << int(i);
      EXPECT_EQ(f.identifier(), 0x181u);
      EXPECT_EQ(f.data[0], i);
      EXPECT_FALSE(f.own);
    }
  }
  Frame f;
  EXPECT_FALSE(a->receive(&f, 20 * kNanosPerMilli));  // no own frames by default
  // c asked for its own frames (CAN_RAW_RECV_OWN_MSGS).
  f.id = 0x701;
  f.len = 1;
  ASSERT_EQ(c->send(f, soon()), SendResult::kSent);
  Frame got;
  ASSERT_TRUE(c->receive(&got, 500 * kNanosPerMilli));
  EXPECT_TRUE(got.own);
  ASSERT_TRUE(a->receive(&got, 500 * kNanosPerMilli));
  EXPECT_EQ(got.identifier(), 0x701u);
  EXPECT_EQ(hub.frames_forwarded(), 51u);
}

TEST(UserSpaceCan, BusOffIsReportedAndRecovered) {
  Hub hub(hub_path());
  auto a = port(hub.path(), 1), b = port(hub.path(), 2);
  settle(hub, 2);
  hub.inject_bus_off(1);
  Frame f;
  ASSERT_TRUE(a->receive(&f, 500 * kNanosPerMilli));
  EXPECT_TRUE(f.is_error());
  EXPECT_TRUE(a->bus_off());
  EXPECT_EQ(a->stats().bus_off, 1u);
  f = {};
  f.id = 0x201;
  EXPECT_EQ(a->send(f, soon()), SendResult::kBusOff);
  const IoError restarted = a->restart();
  ASSERT_TRUE(restarted.ok()) << io_errc_text(restarted.code);
  ASSERT_TRUE(a->receive(&f, 500 * kNanosPerMilli));  // the restarted error frame
  EXPECT_FALSE(a->bus_off());
  f = {};
  f.id = 0x201;
  EXPECT_EQ(a->send(f, soon()), SendResult::kSent);
  ASSERT_TRUE(b->receive(&f, 500 * kNanosPerMilli));
  EXPECT_EQ(f.identifier(), 0x201u);
}

TEST(Can, MissingBackendsAreClearErrors) {
  std::string err;
  EXPECT_EQ(open_port("socketcan:can0", &err), nullptr);
  // These machines' kernel has no CAN; a kernel with CAN but no can0 says so instead.
  EXPECT_TRUE(err.find("interface can0: this kernel has no SocketCAN support") != std::string::npos ||
              err.find("interface can0: no such CAN interface") != std::string::npos)
      << err;
  EXPECT_EQ(open_port("ucan:/tmp/no-such-hub.sock", &err), nullptr);
  EXPECT_NE(err.find("no CAN hub there"), std::string::npos) << err;
  EXPECT_EQ(open_port("can0", &err), nullptr);
  EXPECT_NE(err.find("expected socketcan:IFACE or ucan:PATH"), std::string::npos) << err;
}

}  // namespace
}  // namespace cairn::can
