// libFuzzer target: the MCAP reader (cairn-replay's input). Any bytes: a FormatError or a
// parse whose messages all lie inside the input and name a known channel; never a crash.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "tools/mcap/mcap_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in(data, size);
  try {
    const cairn::mcap::Contents c = cairn::mcap::parse(in);
    for (const auto& m : c.messages) {
      if (!c.channels.contains(m.channel)) std::abort();
      if (m.data.size() > 0 && (m.data.data() < data || m.data.data() + m.data.size() > data + size)) std::abort();
    }
  } catch (const cairn::mcap::FormatError&) {
  }
  return 0;
}
