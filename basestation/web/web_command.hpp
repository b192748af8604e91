// The web view's commands: JSON text from a browser (WebSocket message or POST body) to a
// checked command, or a clear error. Pure: the fuzz target calls it on arbitrary bytes
// (tests/fuzz/web_command_fuzz.cpp); the server never parses anything else from a client.
//   {"cmd": "visit", "robot": 1, "x": 2.5, "y": -1.0}
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cairn::base {

/// Longer commands are refused before parsing (the server also caps messages and bodies).
inline constexpr std::size_t kMaxWebCommandBytes = 1024;

struct WebVisit {
  std::uint16_t robot = 0;  // 1..65535
  double x = 0, y = 0;      // global frame, m; finite
};

struct WebCommandParse {
  std::optional<WebVisit> visit;  // set on success
  std::string error;              // set on failure: what was wrong, for the reply
};

WebCommandParse parse_web_command(std::string_view text);

}  // namespace cairn::base
