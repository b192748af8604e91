// libFuzzer target: the Carmen log line parser (cairn-eval scans). Any bytes: no crash,
// and every line is either a record, skipped or counted as malformed.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "tools/datasets/carmen_log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  cairn::eval::CarmenLog log;
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  std::size_t start = 0;
  std::uint64_t n = 0;
  while (start <= all.size()) {
    const std::size_t end = std::min(all.find('\n', start), all.size());
    cairn::eval::parse_carmen_line(all.substr(start, end - start), ++n, &log);
    start = end + 1;
  }
  for (const auto& s : log.scans)
    if (s.ranges.empty()) std::abort();
  if (log.lines != n) std::abort();
  return 0;
}
