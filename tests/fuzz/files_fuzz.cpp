// libFuzzer target: the files people write or tools exchange. The first byte picks the
// parser: a HIL world file (cairn-hil, cairn-map-quality) or the base's landmarks.json
// (cairn-map-quality). Any bytes: a parsed result or std::runtime_error, nothing else.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "basestation/mapper/export.hpp"
#include "hil/world/world.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    if (data[0] % 2 == 0) {
      const cairn::hil::World w = cairn::hil::World::parse(text, "fuzz.world");
      for (const auto& p : w.poles())
        if (!p.allFinite()) std::abort();
    } else {
      for (const auto& l : cairn::mapper::parse_landmarks_json(text, "fuzz.json"))
        if (!std::isfinite(l.x) || !std::isfinite(l.y)) std::abort();
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
