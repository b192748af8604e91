// Serialized (CDR) samples in and out of DDS, for any Cairn topic: the recorder takes
// what arrives as the bytes that travelled (dds_takecdr) and replay writes those bytes
// back (dds_writecdr), so a replay is byte-exact and needs no per-type code.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "common/dds/participant.hpp"
#include "tools/recording/topic_table.hpp"

struct ddsi_sertype;

namespace cairn::recording {

/// Creates the topic in pp (throws DdsError).
dds::Entity create_topic(const dds::Participant& pp, const TopicEntry& t);

class RawReader {
 public:
  RawReader(const dds::Participant& pp, const TopicEntry& t);
  /// Takes everything available: on_sample(bytes, source_timestamp_ns) for each data sample.
  /// Instance events (dispose, no writers) are counted, not passed on.
  std::size_t take(const std::function<void(std::span<const std::uint8_t>, std::int64_t)>& on_sample);
  dds_entity_t handle() const { return reader_.get(); }
  const TopicEntry& topic() const { return *topic_; }
  std::uint64_t instance_events() const { return instance_events_; }

 private:
  const TopicEntry* topic_;
  dds::Entity topic_entity_;
  dds::Entity reader_;
  std::vector<std::uint8_t> buf_;
  std::uint64_t instance_events_ = 0;
};

class RawWriter {
 public:
  RawWriter(const dds::Participant& pp, const TopicEntry& t);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;
  /// Writes one serialized sample (with its encapsulation header). Returns "" or the reason.
  std::string write(std::span<const std::uint8_t> cdr);
  /// Readers matched now.
  std::uint32_t matched() const;
  /// Waits until the reliable readers acknowledged everything written; false on timeout.
  bool wait_for_acks(std::int64_t timeout_ns) const;
  const TopicEntry& topic() const { return *topic_; }

 private:
  const TopicEntry* topic_;
  dds::Entity topic_entity_;
  dds::Entity writer_;
  const ddsi_sertype* type_ = nullptr;  // referenced; the writer's serialization type
};

}  // namespace cairn::recording
