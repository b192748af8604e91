// The cooperative-CML performance bounds of Fenwick, Newman & Leonard.
#pragma once

#include <cmath>
#include <span>

#include "common/se2.hpp"

namespace cairn::ccml {

/// Eq. 5 / 8: in the limit every vehicle's (and feature's) covariance is the inverse of
/// the sum of the collaborators' initial information: (Σ P_i⁻¹[i_i])⁻¹.
inline Mat2 cooperative_bound(std::span<const Mat2> initial_covariances) {
  Mat2 info = Mat2::Zero();
  for (const Mat2& p : initial_covariances) info += p.inverse();
  return info.inverse();
}

/// Eq. 10 solved exactly: with n identical vehicles P_final = P0 / n, so
/// det(P_final) = det(P0) / n^d for d = 2 position dimensions; the smallest integer n
/// with det(P_final) <= det(P_desired) is ceil((det(P0) / det(P_desired))^(1/2)).
inline int vehicles_needed(const Mat2& desired, const Mat2& initial) {
  const double ratio = initial.determinant() / desired.determinant();
  return std::max(1, static_cast<int>(std::ceil(std::sqrt(ratio) - 1e-9)));
}

/// Eq. 11 exactly as printed in the paper: n = det(P_desired⁻¹) / det(P0⁻¹). Taking the
/// determinant of eq. 10 gives n^d, not n, on the right; for 2-D positions this formula
/// returns n² (see docs/ccml.md). Kept to reproduce the paper's number.
inline double vehicles_needed_paper_eq11(const Mat2& desired, const Mat2& initial) {
  return desired.inverse().determinant() / initial.inverse().determinant();
}

}  // namespace cairn::ccml
