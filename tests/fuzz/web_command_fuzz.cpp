// libFuzzer target: what a browser sends the web view (a WebSocket message or a POST
// body), through the one parser the server uses. Any bytes: a visit with a robot in
// 1..65535 and finite coordinates, or an error text; never both, never neither, no throw.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "basestation/web/web_command.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const cairn::base::WebCommandParse p = cairn::base::parse_web_command(text);
  if (p.command.has_value() == !p.error.empty()) std::abort();
  const bool needs_robot = p.command && (p.command->kind == cairn::base::WebCommandKind::kVisit ||
                                         p.command->kind == cairn::base::WebCommandKind::kReset);
  if (needs_robot && p.command->robot == 0) std::abort();
  if (p.command && (!std::isfinite(p.command->x) || !std::isfinite(p.command->y))) std::abort();
  return 0;
}
