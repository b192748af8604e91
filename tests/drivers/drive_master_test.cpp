// The CANopen master's frame handling, frame by frame on a scripted port and a SimClock
// (no bus, no threads): what the master accepts as a node's feedback and what it refuses.
#include "drivers/canopen/drive_master.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <vector>

namespace cairn::canopen {
namespace {

// A port whose received frames the test queues and whose sent frames it reads back.
class ScriptedPort final : public can::Port {
 public:
  can::SendResult send(const can::Frame& f, Nanos) override {
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
  bool restart(std::string*) override { return true; }
  std::string describe() const override { return "scripted"; }

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

}  // namespace
}  // namespace cairn::canopen
