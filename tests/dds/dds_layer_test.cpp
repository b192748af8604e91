// The RAII DDS layer on the loopback profile: round trips, keyed instances,
// transient-local late joiners, instance events, profile selection, errors.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <map>
#include <optional>
#include <string>
#include <vector>

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

  // The interface and the peers go into Cyclone's XML as they are: checked first.
  auto lan_with = [](const std::string& iface, const std::string& peers) {
    auto d = ConfigDocument::parse("[dds]\nprofile = \"lan\"\ninterface = \"" + iface + "\"\npeers = [" + peers + "]\n", "p.toml");
    return profile_from_config(d.root().optional_section("dds"));
  };
  EXPECT_NO_THROW(lan_with("veth-r1.0", "\"10.0.0.1\", \"fd00::2\", \"[fd00::3]\", \"base.fleet.lan\""));
  for (const char* iface : {"", "eth0\\\"/><x", "an-interface-name", "eth 0", "..", "eth0:1"})
    EXPECT_THROW(lan_with(iface, "\"10.0.0.1\""), ConfigError) << iface;
  for (const char* peers : {"\"239.255.0.1\"", "\"ff02::1\"", "\"0.0.0.0\"", "\"10.0.0.1:7400\"", "\"10.0.0.1\", \"10.0.0.1\"",
                            "\"\"", "\"a..b\"", "\"host/x\"", "\"[10.0.0.1]\"", "\"a b\""})
    EXPECT_THROW(lan_with("eth0", peers), ConfigError) << peers;
  EXPECT_EQ(lan_peer_problem("239.1.2.3"), "239.1.2.3 is a multicast address: peers are unicast");
  EXPECT_THROW(lan_profile("eth0", {}), std::invalid_argument);

  // No [dds] section: CYCLONEDDS_URI if set (ctest sets it to the loopback file), else loopback.
  const char* env = std::getenv("CYCLONEDDS_URI");
  const DdsProfile dflt = profile_from_config(std::nullopt);
  EXPECT_EQ(dflt.name, env && *env ? "env" : "loopback");
}

// Takes one sample of `reader` into `*out` (Cyclone deserializes into the caller's buffer).
template <typename T>
bool take_into(const Reader<T>& reader, T* out) {
  void* samples[1] = {out};
  dds_sample_info_t info;
  return eventually([&] { return dds_take(reader.handle(), samples, &info, 1, 1) == 1 && info.valid_data; });
}

template <typename T, std::size_t N>
void set_text(T (&field)[N], char c) {  // a bounded string filled to its bound
  for (std::size_t i = 0; i + 1 < N; ++i) field[i] = c;
  field[N - 1] = '\0';
}

// Round-trips one sample of topic type T whose every byte is pseudo-random (then enums and
// bounded strings made valid by `fix`). The sample is taken by two readers, into a buffer
// of 0x00 bytes and one of 0xFF bytes: a byte equal in both was written by the
// deserializer and must equal what was sent; bytes that differ were not written, and may
// only be the C struct's padding (`padding`, from the layout; Cyclone copies some types
// whole, padding included, so fewer is fine). The strings are filled to their bound.
template <typename T, typename Fix>
void round_trip(const char* name, std::size_t padding, Fix&& fix) {
  SCOPED_TRACE(name);
  const auto& pp = participant();
  Topic<T> topic(pp);
  Reader<T> zeros(pp, topic, state_qos(4)), ones(pp, topic, state_qos(4));
  auto sent = std::make_unique<T>();
  std::mt19937 rng(static_cast<std::uint32_t>(std::hash<std::string>{}(name)));
  auto* bytes = reinterpret_cast<unsigned char*>(sent.get());
  for (std::size_t i = 0; i < sizeof(T); ++i) bytes[i] = static_cast<unsigned char>(rng());
  fix(*sent);
  auto writer = [&] {  // a robot's topic: written by the sample's robot, in its partition
    if constexpr (PerRobotTopic<T>) {
      return Writer<T>(pp, topic, state_qos(4), sent->robot_id);
    } else {
      return Writer<T>(pp, topic, state_qos(4));
    }
  }();
  ASSERT_TRUE(writer.wait_for_readers(2, 3 * kNanosPerSecond));
  ASSERT_TRUE(writer.write(*sent));
  auto got0 = std::make_unique<T>(), got1 = std::make_unique<T>();
  std::memset(static_cast<void*>(got0.get()), 0x00, sizeof(T));
  std::memset(static_cast<void*>(got1.get()), 0xFF, sizeof(T));
  ASSERT_TRUE(take_into(zeros, got0.get()));
  ASSERT_TRUE(take_into(ones, got1.get()));
  const auto* a = reinterpret_cast<const unsigned char*>(got0.get());
  const auto* b = reinterpret_cast<const unsigned char*>(got1.get());
  std::size_t unwritten = 0, wrong = 0, first_wrong = sizeof(T);
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    if (a[i] != b[i]) {
      ++unwritten;
    } else if (a[i] != bytes[i]) {
      if (wrong++ == 0) first_wrong = i;
    }
  }
  EXPECT_EQ(wrong, 0u) << "of " << sizeof(T) << " bytes; first at offset " << first_wrong;
  EXPECT_LE(unwritten, padding) << "of " << sizeof(T) << " bytes were not delivered: more than the padding";
}

// Sizes and padding of the generated C types (the same on x86-64, aarch64 and armhf: all
// align 8-byte fields to 8). A changed IDL fails here first: update the padding with it.
static_assert(sizeof(cairn_RobotStatus) == 880 && sizeof(cairn_OdometryIncrement) == 152 && sizeof(cairn_LaserScan) == 2320 &&
              sizeof(cairn_FeatureObservations) == 1848 && sizeof(cairn_PoseCorrection) == 136 &&
              sizeof(cairn_TaskAssignment) == 1080 && sizeof(cairn_MapTile) == 4128 && sizeof(cairn_Bid) == 3992 &&
              sizeof(cairn_FeatureMap) == 7200 && sizeof(cairn_SafetyReset) == 56 && sizeof(cairn_SafetyStop) == 48 &&
              sizeof(cairn_VisitRequest) == 64);

TEST(DdsLayer, RoundTripEveryTopicType) {  // all twelve @topic types of common/idl/cairn.idl
  // robot_id (2) + stop_text (3) + n_devices (3) + 6 x DeviceStatus after `state` (3) + nav_state (3)
  // + after remote_stops at the end (4)
  round_trip<cairn_RobotStatus>("RobotStatus", 2 + 3 + 3 + 6 * 3 + 3 + 4, [](cairn_RobotStatus& s) {
    set_text(s.name, 'n');
    set_text(s.stop_text, 's');
    s.mode = cairn_MODE_FAULT;
    for (auto& d : s.devices) {
      set_text(d.name, 'd');
      set_text(d.reason, 'r');
    }
  });
  // robot_id (2) + after boot_epoch at the end (4)
  round_trip<cairn_OdometryIncrement>("OdometryIncrement", 2 + 4, [](cairn_OdometryIncrement&) {});
  round_trip<cairn_LaserScan>("LaserScan", 2 + 7, [](cairn_LaserScan&) {});
  // robot_id (2) + n_features before the 8-aligned features (7)
  round_trip<cairn_FeatureObservations>("FeatureObservations", 2 + 7, [](cairn_FeatureObservations& s) {
    for (auto& f : s.features) f.kind = cairn_FEATURE_ROBOT;
  });
  round_trip<cairn_PoseCorrection>("PoseCorrection", 2, [](cairn_PoseCorrection&) {});
  round_trip<cairn_TaskAssignment>("TaskAssignment", 2 + 4 + 4 + 6, [](cairn_TaskAssignment& s) { s.kind = cairn_TASK_GOTO; });
  // robot_id (2) + after remote_stops_seen at the end (4)
  round_trip<cairn_SafetyReset>("SafetyReset", 2 + 4, [](cairn_SafetyReset& s) { set_text(s.issued_by, 'o'); });
  round_trip<cairn_SafetyStop>("SafetyStop", 2, [](cairn_SafetyStop& s) { set_text(s.issued_by, 'e'); });
  round_trip<cairn_VisitRequest>("VisitRequest", 2, [](cairn_VisitRequest& s) { set_text(s.issued_by, 'v'); });
  round_trip<cairn_MapTile>("MapTile", 2, [](cairn_MapTile&) {});
  // robot_id (2) + after n_items (2) + after n_unreachable (2) + each UnreachableCluster after `kind` (3)
  round_trip<cairn_Bid>("Bid", 2 + 2 + 2 + 16 * 3, [](cairn_Bid&) {});
  // after n_pages (2), after n_landmarks (6), each Landmark: id then 4 to a double
  round_trip<cairn_FeatureMap>("FeatureMap", 2 + 6 + 128 * 4, [](cairn_FeatureMap&) {});
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
    RobotWriters<cairn_RobotStatus> w(pp, topic, state_qos(1), {1, 2});
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
  }  // writers deleted: robot 2 has no writers now
  ASSERT_TRUE(eventually([&] {
    drain();
    return events.size() >= 2;
  }));
  EXPECT_EQ(events[1], std::make_pair(2, InstanceEvent::kNoWriters));
}

TEST(DdsLayer, RobotPartitionNames) {
  EXPECT_STREQ(robot_partition(7).c_str(), "cairn-robot-7");
  EXPECT_STREQ(robot_partition(65535).c_str(), "cairn-robot-65535");
  EXPECT_EQ(robot_of_partition("cairn-robot-7"), 7);
  EXPECT_EQ(robot_of_partition("cairn-robot-65535"), 65535);
  for (const char* p : {"", "cairn-robot-", "cairn-robot-*", "cairn-robot-07", "cairn-robot-65536", "cairn-robot-1x", "robot-1"})
    EXPECT_EQ(robot_of_partition(p), std::nullopt) << p;
}

// Issue 20: a robot's certificate may write only in its own partition, so a sample keyed to
// another robot than its writer's partition says is a robot lying about who it is.
TEST(DdsLayer, PerRobotSamplesAreDeliveredOnlyFromTheirRobotsPartition) {
  const auto& pp = participant();
  Topic<cairn_RobotStatus> topic(pp, "partition_test_status");
  Reader<cairn_RobotStatus> all_robots(pp, topic, state_qos(8));           // cairn-robot-*
  Reader<cairn_RobotStatus> in_default(pp, topic, state_qos(8), nullptr);  // partition ""
  Writer<cairn_RobotStatus> robot1(pp, topic, state_qos(8), 1), robot2(pp, topic, state_qos(8), 2);
  ASSERT_TRUE(robot1.wait_for_readers(1, 3 * kNanosPerSecond));
  ASSERT_TRUE(robot2.wait_for_readers(1, 3 * kNanosPerSecond));
  cairn_RobotStatus s{};
  s.robot_id = 2;
  s.seq = 11;
  ASSERT_TRUE(robot1.write(s));  // robot 1 claims to be robot 2
  s.seq = 22;
  ASSERT_TRUE(robot2.write(s));
  s.robot_id = 1;
  s.seq = 33;
  ASSERT_TRUE(robot1.write(s));

  std::map<std::uint32_t, int> got;  // seq -> robot
  std::vector<std::pair<int, InstanceEvent>> events;
  auto take = [&] {
    all_robots.take([&](const cairn_RobotStatus& r, const dds_sample_info_t&) { got[r.seq] = r.robot_id; },
                    [&](const cairn_RobotStatus& k, InstanceEvent e) { events.emplace_back(k.robot_id, e); });
  };
  ASSERT_TRUE(eventually([&] {
    take();
    return got.size() >= 2 && all_robots.foreign_samples() >= 1;
  })) << got.size() << " delivered, " << all_robots.foreign_samples() << " dropped";
  EXPECT_EQ(got, (std::map<std::uint32_t, int>{{22, 2}, {33, 1}}));
  EXPECT_EQ(all_robots.foreign_samples(), 1u);
  // Robot 1 says robot 2 left: not believed either.
  s.robot_id = 2;
  ASSERT_TRUE(robot1.dispose(s));
  ASSERT_TRUE(eventually([&] {
    take();
    return all_robots.foreign_samples() >= 2;
  }));
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(got.size(), 2u);

  // A reader in the default partition matches none of the robots' writers.
  dds_subscription_matched_status_t matched{};
  ASSERT_GE(dds_get_subscription_matched_status(in_default.handle(), &matched), 0);
  EXPECT_EQ(matched.current_count, 0u);
  std::size_t in_default_got = 0;
  in_default.take([&](const cairn_RobotStatus&, const dds_sample_info_t&) { ++in_default_got; });
  EXPECT_EQ(in_default_got, 0u);
  ASSERT_GE(dds_get_subscription_matched_status(all_robots.handle(), &matched), 0);
  EXPECT_EQ(matched.current_count, 2u);
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
