#include "tools/recording/topic_table.hpp"

#include <array>

#include "common/dds/topics.hpp"
#include "tools/recording/cairn_idl_text.hpp"  // generated: kCairnIdl

namespace cairn::recording {

namespace {

using dds::latched_qos;
using dds::QosSpec;
using dds::sensor_qos;
using dds::state_qos;

template <typename T>
TopicEntry entry(const char* type_name, QosSpec record, QosSpec replay) {
  return {dds::TopicTraits<T>::name, type_name, dds::TopicTraits<T>::descriptor(), record, replay,
          dds::PerRobotTopic<T>};
}

// The recorder keeps a deep history per instance so a burst between two takes is not
// overwritten; its durability is the weakest the topic's readers use, so it matches every
// writer (a transient-local reader would not match a volatile writer), yet a latched
// topic's history reaches a recorder started late. Replay QoS: as firmware/robot_bridge.cpp
// and basestation/ write each topic (the 512-deep fusion history, latched maps and tasks).
const std::array<TopicEntry, 12> kTopics = {
    entry<cairn_RobotStatus>("cairn::RobotStatus", state_qos(64), state_qos(1)),
    entry<cairn_OdometryIncrement>("cairn::OdometryIncrement", latched_qos(512), latched_qos(512)),
    entry<cairn_LaserScan>("cairn::LaserScan", sensor_qos(64), sensor_qos(4)),
    entry<cairn_FeatureObservations>("cairn::FeatureObservations", latched_qos(512), latched_qos(512)),
    entry<cairn_PoseCorrection>("cairn::PoseCorrection", latched_qos(64), latched_qos(1)),
    entry<cairn_TaskAssignment>("cairn::TaskAssignment", latched_qos(64), latched_qos(1)),
    entry<cairn_SafetyReset>("cairn::SafetyReset", state_qos(64), state_qos(4)),
    entry<cairn_SafetyStop>("cairn::SafetyStop", state_qos(64), state_qos(4)),
    entry<cairn_MapTile>("cairn::MapTile", latched_qos(4), latched_qos(1)),
    entry<cairn_Bid>("cairn::Bid", state_qos(64), state_qos(1)),
    entry<cairn_FeatureMap>("cairn::FeatureMap", latched_qos(8), latched_qos(1)),
    entry<cairn_VisitRequest>("cairn::VisitRequest", state_qos(64), state_qos(1)),
};

}  // namespace

std::span<const TopicEntry> cairn_topics() { return kTopics; }

const TopicEntry* find_topic(const std::string& name) {
  for (const TopicEntry& t : kTopics)
    if (name == t.name) return &t;
  return nullptr;
}

const char* cairn_idl_text() { return kCairnIdl; }

}  // namespace cairn::recording
