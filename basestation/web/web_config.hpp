// The base's live web view ([web] in config/base.toml; docs/web-view.md).
#pragma once

#include <cstdint>
#include <string>

#include "common/clock.hpp"

namespace cairn::base {

struct WebConfig {
  bool enabled = false;
  std::string listen = "127.0.0.1";  // loopback by default: put a TLS proxy in front for anything else
  std::uint16_t port = 8080;         // 0: any free port (the base logs the one it bound)
  std::string token;                 // required when enabled; every request and the socket must carry it
  Nanos state_period = 200 * kNanosPerMilli;  // robots, landmarks, tasks pushed at most this often
  Nanos map_period = 2 * kNanosPerSecond;     // the map image at most this often (a whole-map PNG)
};

/// The shortest token [web] accepts: a guessable one would make the 401 decorative.
inline constexpr std::size_t kMinWebTokenLength = 16;

}  // namespace cairn::base
