// Joint Compatibility Branch and Bound (Neira & Tardós 2001) over the observations of
// one scan: individual compatibility gating, then a depth-first branch and bound that
// keeps the hypothesis with the most jointly compatible pairings (ties: lowest joint NIS).
//
// When the observer's own pose is very uncertain (a robot joining the team, the paper's
// B21b experiment) the linearised joint test is meaningless, so the search uses the
// location-independent form: a hypothesis is compatible when every pair of its pairings
// preserves the observed distance between the two points (a rigid-motion invariant),
// and the rigid alignment of all its pairings leaves χ²-consistent residuals. The
// winning hypothesis also yields the aligned pose, from which the filter re-linearises.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "basestation/ccml/filter.hpp"

namespace cairn::ccml {

struct JcbbConfig {
  double confidence = 0.99;        // χ² gate confidence (individual and joint)
  std::size_t max_nodes = 200000;  // search budget per call; exhausting it is reported
  /// Use the location-independent test when the observer's position std exceeds this (m).
  double relocation_sigma = 2.0;
  /// Relocation: the best hypothesis must have this many more pairings than the best rival
  /// whose aligned pose is distinct (differs by more than the two tolerances below);
  /// otherwise the result is `ambiguous` (a symmetric layout fits several poses).
  int relocation_margin = 1;
  double relocation_distinct_m = 0.5;
  double relocation_distinct_rad = 0.2;
};

struct JcbbResult {
  /// For each observation: the feature (jcbb_robots: robot) it pairs with, or nullopt (new
  /// feature / clutter / contested).
  std::vector<std::optional<FeatureId>> pairing;
  int pairings = 0;
  double joint_nis = 0.0;
  std::size_t nodes = 0;
  bool budget_exhausted = false;
  bool relocation_mode = false;
  /// In relocation mode with >= 2 pairings: the observer pose that aligns them.
  std::optional<Pose2> aligned_pose;
  /// Relocation mode: pairings of the best hypothesis with a distinct pose (0: none), and
  /// whether it comes within relocation_margin of the best.
  int rival_pairings = 0;
  /// Relocation: a distinct rival came within the margin. jcbb_robots: some observation was
  /// contested (left unpaired).
  bool ambiguous = false;
};

/// χ² quantile (inverse CDF) for `dof` degrees of freedom.
double chi2_quantile(double confidence, int dof);

/// Associates the observations (range, bearing, covariance) of `observer` with `candidates`.
JcbbResult jcbb(const CcmlFilter& filter, RobotId observer, std::span<const RangeBearing> z,
                std::span<const Mat2> R, std::span<const FeatureId> candidates, const JcbbConfig& config = {});

/// JCBB among robots, for sightings of `observer` whose marker was not read, against the
/// localised robots `candidates` (no relocation mode). A robot sighting has no identity to
/// fall back on, so the most pairings are not enough: every hypothesis with as many
/// pairings is searched, and an observation they do not all pair alike is contested and
/// left unpaired (one sighting, two robots that explain it; two sightings, one robot).
JcbbResult jcbb_robots(const CcmlFilter& filter, RobotId observer, std::span<const RangeBearing> z,
                       std::span<const Mat2> R, std::span<const RobotId> candidates, const JcbbConfig& config = {});

/// Least-squares rigid alignment: the pose T minimising Σ |T·local_i − global_i|².
Pose2 align_points(std::span<const Vec2> local, std::span<const Vec2> global);

}  // namespace cairn::ccml
