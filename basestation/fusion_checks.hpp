// Validation of one input message against the configured limits, before it is logged or
// applied: finiteness, magnitudes, covariance shape (symmetric positive (semi-)definite),
// marker ids. Pure functions of the message; state-dependent checks live in Fusion.
#pragma once

#include <cstdint>
#include <optional>

#include "basestation/reject.hpp"
#include "common/messages.hpp"

namespace cairn::base {

struct FusionLimits {
  double max_step_m = 5.0;             // |δ translation| of one increment
  double max_step_rad = 3.5;           // |δθ| of one increment (> π admits any turn)
  double max_coordinate_m = 1.0e5;     // |x|, |y| of a local pose
  double max_variance = 1.0e4;         // any covariance diagonal entry (m², rad²)
  double max_range_m = 100.0;          // a feature's range
  std::uint32_t max_seq_gap = 10000;   // seq ahead of the last by more than this: implausible
  double innovation_confidence = 0.9999;  // χ² gate on each observation's innovation
};

std::optional<Reject> check(const msg::OdometryIncrement& m, const FusionLimits& limits);
std::optional<Reject> check(const msg::FeatureObservations& m, const FusionLimits& limits);

/// Symmetric (to rounding) with eigenvalues >= 0 (`definite`: > 0) and finite entries.
bool covariance_ok(const Mat3& c, bool definite);
bool covariance_ok(const Mat2& c, bool definite);

}  // namespace cairn::base
