// The CANopen master's frame handling, frame by frame on a scripted port and a SimClock
// (no bus, no threads): what the master accepts as a node's feedback and what it refuses.
#include "drivers/canopen/drive_master.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <functional>
#include <vector>

namespace cairn::canopen {
namespace {

// A port whose received frames the test queues and whose sent frames it reads back.
class ScriptedPort final : public can::Port {
 public:
  can::SendResult send(const can::Frame& f, Nanos) override {
    if (refuse) return can::SendResult::kQueueFull;
    sent.push_back(f);
    return can::SendResult::kSent;
  }
  bool receive(can::Frame* f, Nanos) override {
    if (inbox.empty()) return false;
    *f = inbox.front();
    inbox.pop_front();
    return true;
  }
  const can::BusStats& stats() const override { return stats_; }
  bool bus_off() const override { return false; }
  IoError restart() override { return {}; }
  std::string describe() const override { return "scripted"; }
  void pause(Nanos until) override {
    if (on_pause) on_pause(until);
  }

  std::function<void(Nanos)> on_pause;
  bool refuse = false;  // send() answers kQueueFull
  std::deque<can::Frame> inbox;
  std::vector<can::Frame> sent;

 private:
  can::BusStats stats_;
};

can::Frame tpdo1(std::uint32_t id, std::uint16_t statusword, std::int32_t velocity, Nanos stamp) {
  can::Frame f;
  f.id = id;
  f.len = 6;
  const auto v = static_cast<std::uint32_t>(velocity);
  f.data = {static_cast<std::uint8_t>(statusword), static_cast<std::uint8_t>(statusword >> 8), static_cast<std::uint8_t>(v),
            static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16), static_cast<std::uint8_t>(v >> 24), 0, 0};
  f.stamp = stamp;
  return f;
}

can::Frame tpdo2(std::uint32_t id, std::int32_t position) {
  can::Frame f;
  f.id = id;
  f.len = 4;
  const auto p = static_cast<std::uint32_t>(position);
  f.data = {static_cast<std::uint8_t>(p), static_cast<std::uint8_t>(p >> 8), static_cast<std::uint8_t>(p >> 16),
            static_cast<std::uint8_t>(p >> 24), 0, 0, 0, 0};
  return f;
}

TEST(DriveMaster, ExtendedAndRemoteFramesWithATpdoIdDoNotOverwriteFeedback) {
  SimClock clock(kNanosPerSecond);
  ScriptedPort port;
  MasterConfig cfg;
  cfg.nodes = {1, 0, 0, 0};
  DriveMaster m(&port, &clock, cfg);

  // 29-bit frames whose low 11 bits are node 1's TPDO1 / TPDO2, and RTR frames on those ids.
  port.inbox.push_back(tpdo1(0x181 | can::Frame::kExtended, 0x0627, 1234, clock.now()));
  port.inbox.push_back(tpdo1(0x10000181 | can::Frame::kExtended, 0x0627, 1234, clock.now()));
  port.inbox.push_back(tpdo1(0x181 | can::Frame::kRemote, 0x0627, 1234, clock.now()));
  port.inbox.push_back(tpdo2(0x281 | can::Frame::kExtended, 777));
  port.inbox.push_back(tpdo2(0x281 | can::Frame::kRemote, 777));
  clock.advance(kNanosPerMilli);
  m.step();
  ASSERT_TRUE(port.inbox.empty()) << "the master read every queued frame";
  EXPECT_EQ(m.feedback(0).updates, 0u);
  EXPECT_EQ(m.feedback(0).statusword, 0u);
  EXPECT_EQ(m.feedback(0).velocity, 0);
  EXPECT_EQ(m.feedback(0).position, 0);

  // The same payloads as standard data frames are the drive's feedback.
  port.inbox.push_back(tpdo1(0x181, 0x0627, 1234, clock.now()));
  port.inbox.push_back(tpdo2(0x281, 777));
  clock.advance(kNanosPerMilli);
  m.step();
  EXPECT_EQ(m.feedback(0).updates, 1u);
  EXPECT_EQ(m.feedback(0).statusword, 0x0627u);
  EXPECT_EQ(m.feedback(0).velocity, 1234);
  EXPECT_EQ(m.feedback(0).position, 777);
}

TEST(DriveMaster, ExtendedOrRemoteHeartbeatIdDoesNotStartConfiguration) {
  SimClock clock(kNanosPerSecond);
  ScriptedPort port;
  MasterConfig cfg;
  cfg.nodes = {1, 0, 0, 0};
  DriveMaster m(&port, &clock, cfg);
  can::Frame boot;
  boot.id = 0x701 | can::Frame::kExtended;
  boot.len = 1;
  port.inbox.push_back(boot);
  boot.id = 0x701 | can::Frame::kRemote;
  port.inbox.push_back(boot);
  clock.advance(kNanosPerMilli);
  m.step();
  EXPECT_EQ(m.phase(0), NodePhase::kWaitBoot);
  boot.id = 0x701;
  port.inbox.push_back(boot);
  clock.advance(kNanosPerMilli);
  m.step();
  EXPECT_EQ(m.phase(0), NodePhase::kConfigure);
}

// A clock whose sleeps return at once, moving its time to the deadline: it records how long
// the thread would have slept.
class SteppingClock final : public Clock {
 public:
  explicit SteppingClock(Nanos start) : now_(start) {}
  Nanos now() const override { return now_; }
  void sleep_until(Nanos deadline) override {
    if (deadline > now_) slept += deadline - now_, now_ = deadline;
  }
  void advance(Nanos dt) { now_ += dt; }
  Nanos slept = 0;

 private:
  Nanos now_;
};

// A bus flooded with frames (here another device's PDOs, far more than a step handles): the
// CAN thread must still sleep, most of each slice, instead of spinning on the flood; and
// it still sends its SYNCs.
TEST(DriveMaster, AFloodOfFramesDoesNotKeepTheCanThreadAwake) {
  SteppingClock clock(kNanosPerSecond);
  ScriptedPort port;
  MasterConfig cfg;
  cfg.nodes = {1, 0, 0, 0};
  DriveMaster m(&port, &clock, cfg);
  port.on_pause = [&](Nanos until) { clock.sleep_until(until); };
  can::Frame junk;
  junk.id = 0x18A;  // node 10's TPDO1: not ours
  junk.len = 8;
  for (int i = 0; i < 100 * kMaxFramesPerStep; ++i) port.inbox.push_back(junk);
  const Nanos t0 = clock.now();
  for (int i = 0; i < 100; ++i) {
    clock.advance(10 * kNanosPerMicro);  // the step's own work
    m.step();
  }
  EXPECT_TRUE(port.inbox.empty());
  EXPECT_EQ(m.floods(), 100u);
  // Every step slept out its slice (or to the next SYNC): at least half the time asleep.
  EXPECT_GT(clock.slept, (clock.now() - t0) / 2) << "slept " << clock.slept << " ns of " << clock.now() - t0;
  std::size_t syncs = 0;
  for (const can::Frame& f : port.sent) syncs += f.id == kCobSync;
  EXPECT_GE(static_cast<Nanos>(syncs) + 1, (clock.now() - t0) / cfg.sync_period) << "SYNCs missed under the flood";
}

// A frame the port does not send is counted, not dropped silently (the master's send used
// to discard the port's answer).
TEST(DriveMaster, FramesThePortDoesNotSendAreCounted) {
  SteppingClock clock(kNanosPerSecond);
  ScriptedPort port;
  MasterConfig cfg;
  cfg.nodes = {1, 0, 0, 0};
  DriveMaster m(&port, &clock, cfg);
  EXPECT_EQ(m.send_failures(), 0u);
  port.refuse = true;
  std::size_t steps = 0;
  for (; steps < 100 && m.send_failures() == 0; ++steps) {
    clock.advance(kNanosPerMilli);
    m.step();
  }
  EXPECT_GT(m.send_failures(), 0u) << "SYNCs refused by the port went uncounted";
  const std::uint64_t refused = m.send_failures();
  port.refuse = false;
  for (int i = 0; i < 100; ++i) {
    clock.advance(kNanosPerMilli);
    m.step();
  }
  EXPECT_EQ(m.send_failures(), refused) << "frames the port sent were counted as failures";
  EXPECT_FALSE(port.sent.empty());
}

}  // namespace
}  // namespace cairn::canopen
