// Every Cairn topic with what recording and replay need to know: its type (descriptor
// and IDL name, for the MCAP schema) and the QoS the system's writers and readers use,
// so the recorder's reader matches every writer and a replay writer matches every reader.
#pragma once

#include <dds/dds.h>

#include <span>
#include <string>

#include "common/dds/qos.hpp"

namespace cairn::recording {

struct TopicEntry {
  const char* name;                          // DDS topic name, e.g. "cairn_robot_status"
  const char* type_name;                     // IDL name, e.g. "cairn::RobotStatus" (the MCAP schema name)
  const dds_topic_descriptor_t* descriptor;  // idlc's
  dds::QosSpec record_qos;                   // the recorder's reader
  dds::QosSpec replay_qos;                   // a replay writer: as the original writer
  bool per_robot;                            // robots publish it, each in its partition (common/dds/partition.hpp)
};

/// All topics of common/dds/topics.hpp, in that order.
std::span<const TopicEntry> cairn_topics();
/// The entry for a DDS topic name, or nullptr.
const TopicEntry* find_topic(const std::string& name);

/// common/idl/cairn.idl, compiled in (the schema of every channel).
const char* cairn_idl_text();

}  // namespace cairn::recording
