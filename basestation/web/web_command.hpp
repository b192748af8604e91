// The web view's commands: JSON text from a browser (WebSocket message or POST body) to a
// checked command, or a clear error. Pure: the fuzz target calls it on arbitrary bytes
// (tests/fuzz/web_command_fuzz.cpp); the server never parses anything else from a client.
//   {"cmd": "visit", "robot": 1, "x": 2.5, "y": -1.0}   send robot 1 there (ExploreNode::request_visit)
//   {"cmd": "explore", "run": false}                     stop exploration (true: start it again)
//   {"cmd": "reset", "robot": 1}                         an e-stop reset for robot 1 (SafetyReset)
//   {"cmd": "estop_all"}                                 a remote e-stop for every robot (SafetyStop, id 0)
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cairn::base {

/// Longer commands are refused before parsing (the server also caps messages and bodies).
inline constexpr std::size_t kMaxWebCommandBytes = 1024;

enum class WebCommandKind { kVisit, kExplore, kReset, kEstopAll };
const char* web_command_name(WebCommandKind k);

struct WebCommand {
  WebCommandKind kind = WebCommandKind::kVisit;
  std::uint16_t robot = 0;  // visit, reset: 1..65535
  double x = 0, y = 0;      // visit: global frame, m; finite
  bool run = false;         // explore: start (true) or stop (false)
};

struct WebCommandParse {
  std::optional<WebCommand> command;  // set on success
  std::string error;                  // set on failure: what was wrong, for the reply
};

WebCommandParse parse_web_command(std::string_view text);

}  // namespace cairn::base
