// cairn-fuzz-base reads the base's counters from its console: the `fusion:` line that
// FusionNode::summary() prints every table period and once more at exit ("final fusion:").
#pragma once

#include <map>
#include <string>

namespace cairn::fuzz {

struct FusionLine {
  bool parsed = false;  // the line was found and its counters read
  long long odometry_applied = -1, odometry_dup = -1, odometry_gaps = -1;
  long long features_applied = -1, features_dup = -1;
  long long robots_restarted = -1;
  bool finite = false;                         // "state finite"
  std::map<std::string, long long> rejected;   // "rejected: reason=n ..."
};

/// The last line of `text` that contains `needle` (empty if none).
std::string last_line_with(const std::string& text, const std::string& needle);
/// Reads one `fusion:` line; parsed = false if it is not one.
FusionLine parse_fusion_line(const std::string& line);

}  // namespace cairn::fuzz
