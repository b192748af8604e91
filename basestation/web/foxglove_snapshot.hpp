// What the base offers Foxglove clients at one moment: its channels (topic, schema) and the
// latest message on each, built on the main loop (FoxgloveChannels) and handed to the web
// server as an immutable snapshot. The server thread only frames and sends these.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace cairn::base {

struct FoxgloveChannel {
  std::uint32_t id = 0;  // the same id always means the same topic and schema
  std::string topic;
  std::string schema_name;   // "foxglove.Grid", ... or a Cairn name
  std::string_view schema;   // JSON Schema text (static storage: foxglove_schemas.hpp)
  std::shared_ptr<const std::string> payload;  // the latest message, JSON; null: none yet
  std::uint64_t version = 0;  // changes with payload: a client gets each version at most once
  std::uint64_t stamp_ns = 0;  // when it was built, ns since the Unix epoch (messageData's timestamp)
};

struct FoxgloveSnapshot {
  std::vector<FoxgloveChannel> channels;  // ascending id
};

}  // namespace cairn::base
