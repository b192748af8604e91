#include "tools/fuzz_base/base_summary.hpp"

#include <cstdio>
#include <sstream>

namespace cairn::fuzz {

std::string last_line_with(const std::string& text, const std::string& needle) {
  const auto at = text.rfind(needle);
  if (at == std::string::npos) return {};
  const auto begin = text.rfind('\n', at);
  const auto end = text.find('\n', at);
  const auto from = begin == std::string::npos ? 0 : begin + 1;
  return text.substr(from, end == std::string::npos ? std::string::npos : end - from);
}

FusionLine parse_fusion_line(const std::string& line) {
  FusionLine f;
  const auto at = line.find("fusion: odometry ");
  if (at == std::string::npos) return f;
  const int n = std::sscanf(line.c_str() + at, "fusion: odometry %lld applied (%lld dup, %lld gaps), features %lld applied (%lld dup,",
                            &f.odometry_applied, &f.odometry_dup, &f.odometry_gaps, &f.features_applied, &f.features_dup);
  const auto loc = line.find(" localised, ");
  if (n != 5 || loc == std::string::npos || std::sscanf(line.c_str() + loc, " localised, %lld restarted", &f.robots_restarted) != 1) {
    return f;
  }
  f.finite = line.find(", state finite;") != std::string::npos;
  const auto rej = line.find("rejected: ");
  if (rej == std::string::npos) return f;
  std::istringstream in(line.substr(rej + 10));
  std::string tok;
  while (in >> tok) {  // "a=1 b=2; persistence: ..." or "none; ..."
    const bool last = tok.back() == ';';
    if (last) tok.pop_back();
    const auto eq = tok.find('=');
    if (eq == std::string::npos) break;
    f.rejected[tok.substr(0, eq)] = std::atoll(tok.c_str() + eq + 1);
    if (last) break;
  }
  f.parsed = true;
  return f;
}

}  // namespace cairn::fuzz
