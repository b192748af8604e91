// The base station's one vocabulary for what it refuses: every input message or observation
// that is not applied is counted under exactly one reason, never thrown out of the loop.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace cairn::base {

enum class Reject : std::uint8_t {
  // Whole messages.
  kMalformed,          // a DDS sample whose counts or enums had to be clamped (from_dds)
  kNonFinite,          // NaN or inf in a pose, delta, range, bearing or covariance
  kOutOfBounds,        // a magnitude beyond [fusion.limits] (step, coordinate, variance, range)
  kBadCovariance,      // not symmetric positive (semi-)definite
  kBadMarker,          // a robot marker id outside [1, 65535] or the observer's own id
  kSeqJump,            // seq (or odom_seq) ahead of the last by more than limits.max_seq_gap
  kUnknownRobot,       // robot not in the configured fleet and unknown robots not allowed (or id 0)
  kRobotCap,           // unknown robots allowed, but already max_robots of them
  kStaleEpoch,         // from a boot epoch the robot has since left (a retired epoch)
  kApplyFailed,        // applying (live or on replay) threw: skipped, the loop goes on
  // Single observations (or one scan's association).
  kInnovationGate,     // the observation's innovation failed the χ² gate
  kBeyondRange,        // landmark beyond candidate_range: could never be matched again
  kAmbiguousNew,       // unpaired, but too close to an existing feature to start a new one
  kLandmarkCap,        // a new landmark refused: the map holds max_landmarks
  kFilterRefused,      // the filter refused a step whose result would not be finite
  kRelocationAmbiguous,  // relocation refused: the best hypothesis does not beat a distinct rival by the margin
  kSearchIncomplete,   // JCBB's node budget ran out: its answer is not the best, not used
  kCount
};

const char* reject_name(Reject r);

struct RejectCounters {
  std::array<std::uint64_t, static_cast<std::size_t>(Reject::kCount)> n{};
  void count(Reject r, std::uint64_t k = 1) { n[static_cast<std::size_t>(r)] += k; }
  std::uint64_t operator[](Reject r) const { return n[static_cast<std::size_t>(r)]; }
  std::uint64_t total() const;
  /// "name=count ..." for the non-zero reasons ("none" if there are none).
  std::string summary() const;
};

}  // namespace cairn::base
