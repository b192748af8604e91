// libFuzzer target: what a Foxglove client sends the base (a text op), through the one
// parser the server uses. Any bytes: a subscribe or unsubscribe with 1..64 entries and no
// error, or an error text and nothing else; no throw.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "basestation/web/foxglove_op.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using cairn::base::FoxgloveOp;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const FoxgloveOp op = cairn::base::parse_foxglove_op(text);
  const std::size_t n = op.subscribe.size() + op.unsubscribe.size();
  switch (op.kind) {
    case FoxgloveOp::Kind::kError:
      if (op.error.empty() || n != 0) std::abort();
      break;
    case FoxgloveOp::Kind::kSubscribe:
      if (!op.error.empty() || op.subscribe.empty() || !op.unsubscribe.empty()) std::abort();
      break;
    case FoxgloveOp::Kind::kUnsubscribe:
      if (!op.error.empty() || op.unsubscribe.empty() || !op.subscribe.empty()) std::abort();
      break;
  }
  if (n > cairn::base::kMaxFoxgloveOpEntries) std::abort();
  return 0;
}
