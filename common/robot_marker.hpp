// The coded retroreflective marker every robot wears around its body (docs/markers.md):
// the one definition the HIL world (which lasers see) and the robot's decoder share.
//
// The circumference is cut into 30° cells; the tape pattern repeats every 120° (four
// cells), so whatever side a laser sees, the visible half holds a whole run of tape or of
// bare body. A code is told by the arc of its runs:
//   code 1: 30° tape, 90° bare     code 2: 60° tape, 60° bare     code 3: 90° tape, 30° bare
// Each run length belongs to one code only (a 30° tape run is code 1, a 30° bare run code
// 3, a 90° tape run code 3, ...), so one run read is enough. A robot whose id has no code
// wears tape all round: a plain marker, seen as a robot without identity.
#pragma once

#include <cmath>
#include <numbers>

namespace cairn::marker {

inline constexpr int kCodes = 3;                                // robot ids 1..3 are coded
inline constexpr double kCellRad = std::numbers::pi / 6;        // 30°
inline constexpr double kPeriodRad = 4 * kCellRad;              // 120°: three periods round the body

/// The code robot `robot_id` wears: itself for 1..kCodes, 0 (plain, tape all round) otherwise.
constexpr int code_of(int robot_id) { return robot_id >= 1 && robot_id <= kCodes ? robot_id : 0; }

/// Arc of one tape run and of one bare run of a code (1..kCodes).
constexpr double tape_arc(int code) { return code * kCellRad; }
constexpr double bare_arc(int code) { return kPeriodRad - tape_arc(code); }

/// Whether robot `robot_id`'s body is taped at `body_angle` (rad, counter-clockwise from
/// its heading).
inline bool taped_at(int robot_id, double body_angle) {
  const int code = code_of(robot_id);
  if (code == 0) return true;
  double a = std::fmod(body_angle, kPeriodRad);
  if (a < 0) a += kPeriodRad;
  return a < tape_arc(code);
}

}  // namespace cairn::marker
