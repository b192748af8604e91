// Serialized (CDR) samples in and out of DDS, for any Cairn topic: the recorder takes
// what arrives as the bytes that travelled (dds_takecdr) and replay writes those bytes
// back (dds_writecdr), so a replay is byte-exact and needs no per-type code.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/dds/participant.hpp"
#include "common/dds/partition.hpp"
#include "tools/recording/topic_table.hpp"

struct ddsi_sertype;

namespace cairn::recording {

/// Creates the topic in pp (throws DdsError).
dds::Entity create_topic(const dds::Participant& pp, const TopicEntry& t);

/// The robot_id of a serialized sample (every Cairn topic's first member and key), or
/// nullopt if the bytes are too short or of an encoding it does not know.
std::optional<std::uint16_t> cdr_robot_id(std::span<const std::uint8_t> cdr);

class RawReader {
 public:
  /// A per-robot topic is read in every robot's partition.
  RawReader(const dds::Participant& pp, const TopicEntry& t);
  /// Takes everything available: on_sample(bytes, source_timestamp_ns) for each data sample.
  /// Instance events (dispose, no writers) are counted, not passed on; so is a per-robot
  /// topic's sample keyed to another robot than its writer's partition (dropped, as the base does).
  std::size_t take(const std::function<void(std::span<const std::uint8_t>, std::int64_t)>& on_sample);
  dds_entity_t handle() const { return reader_.get(); }
  const TopicEntry& topic() const { return *topic_; }
  std::uint64_t instance_events() const { return instance_events_; }
  std::uint64_t foreign_samples() const { return foreign_samples_; }

 private:
  const TopicEntry* topic_;
  dds::Entity topic_entity_;
  dds::Entity subscriber_;  // a per-robot topic's, in every robot's partition
  dds::Entity reader_;
  dds::WriterRobots writer_robots_;
  std::vector<std::uint8_t> buf_;
  std::uint64_t instance_events_ = 0;
  std::uint64_t foreign_samples_ = 0;
};

/// A per-robot topic's replay writes each sample in its robot's partition, as that robot did:
/// one writer per robot, made by add_robot (before the replay, so readers match it first) or
/// on the robot's first sample.
class RawWriter {
 public:
  RawWriter(const dds::Participant& pp, const TopicEntry& t);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;
  /// Makes robot `robot_id`'s writer of a per-robot topic now (no-op otherwise).
  void add_robot(std::uint16_t robot_id);
  /// Writes one serialized sample (with its encapsulation header). Returns "" or the reason.
  std::string write(std::span<const std::uint8_t> cdr);
  /// Readers matched now (the fewest of any robot's writer).
  std::uint32_t matched() const;
  /// Waits until the reliable readers acknowledged everything written; false on timeout.
  bool wait_for_acks(std::int64_t timeout_ns) const;
  const TopicEntry& topic() const { return *topic_; }

 private:
  struct RobotWriter {
    dds::Entity publisher;  // in the robot's partition
    dds::Entity writer;     // declared last: deleted first
  };
  dds_entity_t writer_for(std::span<const std::uint8_t> cdr);

  const dds::Participant* pp_;
  const TopicEntry* topic_;
  dds::Entity topic_entity_;
  dds::Entity writer_;                            // a topic robots do not publish
  std::map<std::uint16_t, RobotWriter> robots_;  // a per-robot topic: robot id -> its writer
  const ddsi_sertype* type_ = nullptr;  // referenced; the writers' serialization type
};

}  // namespace cairn::recording
