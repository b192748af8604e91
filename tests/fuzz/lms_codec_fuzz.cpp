// libFuzzer target: the LMS2xx reply parser and every decoder, on arbitrary bytes.
#include <cstddef>
#include <cstdint>

#include "drivers/sick/lms_codec.hpp"

using namespace cairn::lms;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Parser p(kReplyAddress);
  std::span<const std::uint8_t> rest(data, size);
  while (!rest.empty()) {
    std::size_t used = 0;
    if (p.feed(rest, &used) == Parser::Event::kTelegram) {
      const Telegram& t = p.telegram();
      ScanValues v;
      for (std::uint8_t mode : {0x00, 0x01, 0x03, 0x05, 0x06, 0x0F}) decode_values(t, mode, &v);
      VariantReply vr;
      decode_variant(t, &vr);
      StatusReply sr;
      decode_status(t, &sr);
    }
    if (used == 0) __builtin_trap();  // the parser must always make progress
    rest = rest.subspan(used);
  }
  return 0;
}
