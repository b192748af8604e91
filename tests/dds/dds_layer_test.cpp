// The RAII DDS layer on the loopback profile: round trips, keyed instances,
// transient-local late joiners, instance events, profile selection, errors.
#include <gtest/gtest.h>

#include <cstdlib>

#include "common/config.hpp"
#include "common/dds/topics.hpp"

namespace cairn::dds {
namespace {

constexpr std::uint32_t kDomain = 101;  // this test's own domain: parallel tests do not see each other

const Participant& participant() {
  static Participant pp(loopback_profile(kDomain));
  return pp;
}

template <typename Pred>
bool eventually(Pred pred, Nanos timeout = 3 * kNanosPerSecond) {
  const Nanos end = MonotonicClock::instance().now() + timeout;
  while (MonotonicClock::instance().now() < end) {
    if (pred()) return true;
    dds_sleepfor(DDS_MSECS(5));
  }
  return pred();
}

TEST(DdsProfile, LoopbackIsConfinedToLo) {
  const std::string& xml = loopback_xml();
  EXPECT_NE(xml.find("<NetworkInterface name=\"lo\"/>"), std::string::npos);
  EXPECT_NE(xml.find("<AllowMulticast>false</AllowMulticast>"), std::string::npos);
  EXPECT_NE(xml.find("<Peer address=\"127.0.0.1\"/>"), std::string::npos);
  EXPECT_NE(xml.find("<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"), std::string::npos);
  EXPECT_TRUE(loopback_profile().loopback_only);
}

TEST(DdsProfile, FromConfig) {
  auto doc = ConfigDocument::parse("[dds]\nprofile = \"lan\"\ninterface = \"eth0\"\npeers = [\"10.1.2.3\"]\ndomain = 7\n", "x.toml");
  const DdsProfile lan = profile_from_config(doc.root().optional_section("dds"));
  EXPECT_EQ(lan.name, "lan");
  EXPECT_EQ(lan.domain, 7u);
  EXPECT_NE(lan.xml.find("<NetworkInterface name=\"eth0\"/>"), std::string::npos);
  EXPECT_NE(lan.xml.find("<Peer address=\"10.1.2.3\"/>"), std::string::npos);
  EXPECT_FALSE(lan.loopback_only);

  auto bad = ConfigDocument::parse("[dds]\nprofile = \"wifi\"\n", "y.toml");
  EXPECT_THROW(profile_from_config(bad.root().optional_section("dds")), ConfigError);
  auto nopeers = ConfigDocument::parse("[dds]\nprofile = \"lan\"\ninterface = \"eth0\"\npeers = []\n", "z.toml");
  EXPECT_THROW(profile_from_config(nopeers.root().optional_section("dds")), ConfigError);

  // No [dds] section: CYCLONEDDS_URI if set (ctest sets it to the loopback file), else loopback.
  const char* env = std::getenv("CYCLONEDDS_URI");
  const DdsProfile dflt = profile_from_config(std::nullopt);
  EXPECT_EQ(dflt.name, env && *env ? "env" : "loopback");
}

TEST(DdsLayer, RoundTripEveryTopicType) {
  const auto& pp = participant();
  Topic<cairn_LaserScan> topic(pp);
  Reader<cairn_LaserScan> reader(pp, topic, state_qos(4));
  Writer<cairn_LaserScan> writer(pp, topic, state_qos(4));
  ASSERT_TRUE(writer.wait_for_readers(1, 3 * kNanosPerSecond));
  auto scan = std::make_unique<cairn_LaserScan>();
  scan->robot_id = 4;
  scan->seq = 77;
  scan->n_beams = cairn_MAX_BEAMS;
  for (int i = 0; i < cairn_MAX_BEAMS; ++i) scan->ranges_mm[i] = static_cast<std::uint16_t>(i * 7);
  scan->pose = to_msg(Pose2{1.5, -2.0, 0.25});
  ASSERT_TRUE(writer.write(*scan));
  bool got = false;
  ASSERT_TRUE(eventually([&] {
    reader.take([&](const cairn_LaserScan& s, const dds_sample_info_t&) {
      EXPECT_EQ(s.robot_id, 4);
      EXPECT_EQ(s.seq, 77u);
      EXPECT_EQ(s.ranges_mm[720], 720 * 7);
      EXPECT_DOUBLE_EQ(from_msg(s.pose).theta, 0.25);
      got = true;
    });
    return got;
  }));
}

TEST(DdsLayer, KeepLastIsPerRobot) {
  const auto& pp = participant();
  Topic<cairn_PoseCorrection> topic(pp);
  Reader<cairn_PoseCorrection> reader(pp, topic, state_qos(1));
  Writer<cairn_PoseCorrection> writer(pp, topic, state_qos(1));
  ASSERT_TRUE(writer.wait_for_readers(1, 3 * kNanosPerSecond));
  for (std::uint16_t robot = 1; robot <= 3; ++robot) {
    for (std::uint32_t seq = 1; seq <= 3; ++seq) {
      cairn_PoseCorrection c{};
      c.robot_id = robot;
      c.seq = seq;
      ASSERT_TRUE(writer.write(c));
    }
  }
  dds_sleepfor(DDS_MSECS(200));
  std::map<int, std::uint32_t> latest;
  reader.take([&](const cairn_PoseCorrection& c, const dds_sample_info_t&) { latest[c.robot_id] = c.seq; });
  EXPECT_EQ(latest.size(), 3u);
  for (auto& [robot, seq] : latest) EXPECT_EQ(seq, 3u) << "robot " << robot;
}

TEST(DdsLayer, TransientLocalReachesLateJoiner) {
  const auto& pp = participant();
  Topic<cairn_TaskAssignment> topic(pp);
  Writer<cairn_TaskAssignment> writer(pp, topic, latched_qos());
  cairn_TaskAssignment t{};
  t.robot_id = 9;
  t.task_id = 1234;
  t.kind = cairn_TASK_GOTO;
  ASSERT_TRUE(writer.write(t));
  Reader<cairn_TaskAssignment> late(pp, topic, latched_qos());  // created after the write
  std::uint32_t got = 0;
  ASSERT_TRUE(eventually([&] {
    late.take([&](const cairn_TaskAssignment& s, const dds_sample_info_t&) { got = s.task_id; });
    return got == 1234;
  }));
}

TEST(DdsLayer, DisposeAndWriterLossAreReportedAsEvents) {
  const auto& pp = participant();
  Topic<cairn_RobotStatus> topic(pp);
  Reader<cairn_RobotStatus> reader(pp, topic, state_qos(1));
  std::vector<std::pair<int, InstanceEvent>> events;
  auto drain = [&] {
    reader.take([](const cairn_RobotStatus&, const dds_sample_info_t&) {},
                [&](const cairn_RobotStatus& k, InstanceEvent e) { events.emplace_back(k.robot_id, e); });
  };
  {
    Writer<cairn_RobotStatus> w(pp, topic, state_qos(1));
    ASSERT_TRUE(w.wait_for_readers(1, 3 * kNanosPerSecond));
    cairn_RobotStatus s{};
    s.robot_id = 1;
    ASSERT_TRUE(w.write(s));
    s.robot_id = 2;
    ASSERT_TRUE(w.write(s));
    s.robot_id = 1;
    ASSERT_TRUE(w.dispose(s));
    ASSERT_TRUE(eventually([&] {
      drain();
      return !events.empty();
    }));
    EXPECT_EQ(events[0], std::make_pair(1, InstanceEvent::kDisposed));
  }  // writer deleted: robot 2 has no writers now
  ASSERT_TRUE(eventually([&] {
    drain();
    return events.size() >= 2;
  }));
  EXPECT_EQ(events[1], std::make_pair(2, InstanceEvent::kNoWriters));
}

TEST(DdsLayer, ErrorsNameTheCall) {
  DdsProfile bad = loopback_profile(199);
  bad.xml = "<CycloneDDS><Domain><General><Interfaces><NetworkInterface name=\"no-such-if0\"/></Interfaces></General></Domain></CycloneDDS>";
  try {
    Participant pp(bad);
    FAIL() << "a participant on a missing interface must not be created";
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("dds_create_"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cairn::dds
