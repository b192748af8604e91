// A Carmen log reader (FLASER and ODOM records; plain text or gzip). Malformed lines
// are skipped and counted with the first few line numbers and reasons; nothing throws
// for bad content, only for a file that cannot be opened.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/se2.hpp"

namespace cairn::eval {

struct CarmenScan {
  std::vector<float> ranges;  // metres
  Pose2 pose;                 // laser pose (corrected logs: the reference)
  Pose2 odom;                 // odometry pose as logged
  double stamp = 0;           // ipc_timestamp
};

struct CarmenOdom {
  Pose2 pose;
  double tv = 0, rv = 0, stamp = 0;
};

struct CarmenLog {
  std::vector<CarmenScan> scans;
  std::vector<CarmenOdom> odom;
  std::uint64_t lines = 0, skipped = 0, bad = 0;  // skipped: other record types
  std::vector<std::string> errors;                // the first few bad lines, "line N: why"
};

/// Parses one line into `log` (exposed for the fuzz target).
void parse_carmen_line(std::string_view line, std::uint64_t line_no, CarmenLog* log);
/// Reads a whole log (gzip or plain); throws std::runtime_error if it cannot be opened.
CarmenLog read_carmen_log(const std::string& path);

/// Beam angles of a Carmen FLASER with n readings: a 180° field of view, first beam at -90°.
inline double carmen_beam_angle(std::size_t i, std::size_t n) {
  const double fov = 3.14159265358979323846;
  const double step = n == 181 ? fov / 180.0 : fov / static_cast<double>(n);
  return -fov / 2 + static_cast<double>(i) * step;
}

}  // namespace cairn::eval
