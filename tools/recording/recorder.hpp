// cairn-record's work: one serialized reader per Cairn topic, each sample taken written
// to an MCAP file as a Message on the topic's channel (schema: the IDL; encoding: cdr).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/dds/participant.hpp"
#include "tools/mcap/mcap_writer.hpp"
#include "tools/recording/raw_topic.hpp"

namespace cairn::recording {

class Recorder {
 public:
  /// Creates the readers and writes the schemas and channels (throws DdsError, WriteError).
  Recorder(const dds::Participant& pp, mcap::Writer& out);
  /// Waits up to timeout_ns for data, then writes everything available. Throws WriteError.
  std::size_t poll(std::int64_t timeout_ns);
  /// "cairn_odometry 1200, cairn_features 600, ..." (topics with messages only).
  std::string counts() const;
  /// Disposals and writers gone (instance events): seen, not recorded.
  std::uint64_t instance_events() const;

 private:
  struct Channel {
    std::unique_ptr<RawReader> reader;
    std::uint16_t id = 0;
    std::uint32_t sequence = 0;
  };
  mcap::Writer& out_;
  std::vector<Channel> channels_;
  dds::Entity waitset_;
};

}  // namespace cairn::recording
