#include "basestation/reject.hpp"

namespace cairn::base {

const char* reject_name(Reject r) {
  switch (r) {
    case Reject::kMalformed: return "malformed";
    case Reject::kNonFinite: return "non_finite";
    case Reject::kOutOfBounds: return "out_of_bounds";
    case Reject::kBadCovariance: return "bad_covariance";
    case Reject::kBadMarker: return "bad_marker";
    case Reject::kSeqJump: return "seq_jump";
    case Reject::kUnknownRobot: return "unknown_robot";
    case Reject::kRobotCap: return "robot_cap";
    case Reject::kStaleEpoch: return "stale_epoch";
    case Reject::kApplyFailed: return "apply_failed";
    case Reject::kInnovationGate: return "innovation_gate";
    case Reject::kBeyondRange: return "beyond_range";
    case Reject::kAmbiguousNew: return "ambiguous_new";
    case Reject::kLandmarkCap: return "landmark_cap";
    case Reject::kFilterRefused: return "filter_refused";
    case Reject::kRelocationAmbiguous: return "relocation_ambiguous";
    case Reject::kSearchIncomplete: return "search_incomplete";
    case Reject::kCount: break;
  }
  return "?";
}

std::uint64_t RejectCounters::total() const {
  std::uint64_t t = 0;
  for (std::uint64_t v : n) t += v;
  return t;
}

std::string RejectCounters::summary() const {
  std::string s;
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (n[i] == 0) continue;
    if (!s.empty()) s += ' ';
    s += reject_name(static_cast<Reject>(i));
    s += '=';
    s += std::to_string(n[i]);
  }
  return s.empty() ? "none" : s;
}

}  // namespace cairn::base
