#include "basestation/fusion_checks.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace cairn::base {

namespace {

bool finite(const Pose2& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta); }

template <typename M>
bool spd(const M& c, bool definite) {
  if (!c.allFinite()) return false;
  const double scale = std::max(1e-300, c.cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  const M sym = 0.5 * (c + c.transpose());
  const double min_eig = Eigen::SelfAdjointEigenSolver<M>(sym, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  return definite ? min_eig > 0 : min_eig >= -1e-12 * scale;
}

}  // namespace

bool covariance_ok(const Mat3& c, bool definite) { return spd(c, definite); }
bool covariance_ok(const Mat2& c, bool definite) { return spd(c, definite); }

std::optional<Reject> check(const msg::OdometryIncrement& m, const FusionLimits& lim) {
  const Mat3 c = msg::to_mat(m.delta_cov);
  if (!finite(m.delta) || !finite(m.local_pose) || !c.allFinite()) return Reject::kNonFinite;
  if (std::hypot(m.delta.x, m.delta.y) > lim.max_step_m || std::abs(m.delta.theta) > lim.max_step_rad ||
      std::abs(m.local_pose.x) > lim.max_coordinate_m || std::abs(m.local_pose.y) > lim.max_coordinate_m ||
      c.diagonal().maxCoeff() > lim.max_variance) {
    return Reject::kOutOfBounds;
  }
  if (!covariance_ok(c, /*definite=*/false)) return Reject::kBadCovariance;
  return std::nullopt;
}

std::optional<Reject> check(const msg::FeatureObservations& m, const FusionLimits& lim) {
  if (m.n_features > msg::kMaxFeatures) return Reject::kMalformed;
  if (!finite(m.local_pose)) return Reject::kNonFinite;
  if (std::abs(m.local_pose.x) > lim.max_coordinate_m || std::abs(m.local_pose.y) > lim.max_coordinate_m) return Reject::kOutOfBounds;
  for (std::size_t i = 0; i < m.n_features; ++i) {
    const msg::Feature& f = m.features[i];
    const Mat2 c = msg::to_mat(f.cov);
    if (!std::isfinite(f.range) || !std::isfinite(f.bearing) || !c.allFinite()) return Reject::kNonFinite;
    if (f.range <= 0 || f.range > lim.max_range_m || std::abs(f.bearing) > 8.0 || c.diagonal().maxCoeff() > lim.max_variance) {
      return Reject::kOutOfBounds;
    }
    if (!covariance_ok(c, /*definite=*/true)) return Reject::kBadCovariance;
    if (f.kind == msg::FeatureKind::kRobot && f.marker_id != -1 &&  // -1: a marker seen but not decoded
        (f.marker_id < 1 || f.marker_id > 65535 || f.marker_id == static_cast<std::int32_t>(m.robot_id))) {
      return Reject::kBadMarker;
    }
  }
  return std::nullopt;
}

}  // namespace cairn::base
