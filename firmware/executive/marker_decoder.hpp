// Reads a robot's marker code (common/robot_marker.hpp) from the beams of one scan that hit
// its body. Each beam is placed on the body by its angle round the body's circumference;
// a change of tape between two neighbouring beams is an edge somewhere between them, so a
// run bounded by two edges is known to within half the gap at each end. A code is read when
// the runs agree, within those bounds, with exactly one code: a whole run as long as that
// code's run of its kind, a run cut off by the ends of the view no longer. Runs that
// several codes would allow (far away, at a grazing angle, or only cut runs seen short)
// leave the marker unread rather than guessed. Pure; no allocation; work linear in the beams.
#pragma once

#include <cstddef>

namespace cairn::firmware {

struct BodyBeam {
  double phi = 0;      // rad round the body, from the point facing the laser; monotonic in scan order
  bool taped = false;  // the LMS flagged the return
};

inline constexpr int kMarkerUnread = -1;
inline constexpr int kMarkerPlain = 0;  // tape all round: a robot without a code

/// The code (1..marker::kCodes), kMarkerPlain, or kMarkerUnread. `margin_rad` is added to
/// every run's bounds for the error in placing beams on the body (centre fit, noise).
int decode_marker(const BodyBeam* beams, std::size_t n, double margin_rad);

}  // namespace cairn::firmware
