// What a Foxglove client sends the base (the text ops of the Foxglove WebSocket protocol,
// subprotocol foxglove.websocket.v1): JSON text to a checked subscribe or unsubscribe, or
// a clear error for the status reply. Pure: the fuzz target calls it on arbitrary bytes
// (tests/fuzz/foxglove_op_fuzz.cpp); the server parses nothing else from a Foxglove client.
//   {"op": "subscribe", "subscriptions": [{"id": 0, "channelId": 3}]}
//   {"op": "unsubscribe", "subscriptionIds": [0]}
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cairn::base {

/// Longer ops are refused before parsing (the server also caps socket messages at this).
inline constexpr std::size_t kMaxFoxgloveOpBytes = 8 * 1024;
/// Entries in one subscribe or unsubscribe; more is an error (a connection's total is capped apart).
inline constexpr std::size_t kMaxFoxgloveOpEntries = 64;

struct FoxgloveSubscription {
  std::uint32_t id = 0;          // chosen by the client
  std::uint32_t channel_id = 0;  // from our advertise
};

struct FoxgloveOp {
  enum class Kind : std::uint8_t { kError, kSubscribe, kUnsubscribe };
  Kind kind = Kind::kError;
  std::vector<FoxgloveSubscription> subscribe;  // kSubscribe: at least one
  std::vector<std::uint32_t> unsubscribe;       // kUnsubscribe: at least one
  std::string error;                            // kError: what was wrong
};

FoxgloveOp parse_foxglove_op(std::string_view text);

}  // namespace cairn::base
