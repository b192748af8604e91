// The statistics of `cairn-eval explore` (issue 15 item 4): exploration runs grouped by
// mode and robot count, times to the seed's coverage levels (mean, spread, runs that
// reached them), completed and failed runs, the mean coverage curve, and the ratios the
// issue's goals are stated in. Pure: the runs are made by the caller (explore_cmd.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cairn::eval {

/// The coverage levels of the seed's figures 8-10.
inline constexpr double kExploreLevels[4] = {0.50, 0.90, 0.95, 1.00};

/// A run whose final map agrees with the world's truth on fewer than this fraction of its
/// known cells is counted as a failure ("the resultant map was qualitatively wrong", seed
/// §5). Fixed before any grid was run: the scripted tours give 0.96, exploration runs
/// 0.81-0.92, and a map drawn in a wrong frame about 0.84 over a small area but far less
/// over a whole building.
inline constexpr double kFailureAgreement = 0.75;

struct ExploreRun {
  std::string mode;  // "coordinated" or "uncoordinated"
  int robots = 0;
  int run = 0;  // 0-based index within its group
  std::uint64_t seed = 0;
  std::string world;
  std::optional<double> time_to[4];  // s to kExploreLevels[k]; nullopt: not reached
  bool explored = false;             // the base reported the world explored before the cap
  double explored_at_s = 0;
  double final_coverage = 0, agreement = 0, wall_offset_max_m = 0;
  double final_drivable = 0;  // coverage of the space the robots' bodies can sweep (drivable_space.hpp)
  double distance_m = 0;  // all robots
  std::uint64_t bump_steps = 0;
  std::optional<double> closest_approach_m;  // between two robots' centres (none with one robot)
  std::vector<double> curve_t, curve_coverage;  // the recorded coverage
  double wall_s = 0;
};

bool is_failure(const ExploreRun& r);

struct LevelStats {
  std::size_t reached = 0;  // runs that reached the level
  std::optional<double> mean, sd, min, max;  // over those runs; sd needs two
};

struct ExploreGroup {
  std::string mode;
  int robots = 0;
  std::size_t runs = 0, completed = 0, failures = 0;
  LevelStats level[4];
  double coverage_mean = 0, agreement_mean = 0, drivable_mean = 0;
  double explored_at_mean = 0;  // over completed runs
  std::optional<double> closest_approach_min_m;  // over the runs (none with one robot)
  std::uint64_t bump_steps = 0;                   // all runs
  /// The mean coverage on a common time grid (runs that ended hold their final value).
  std::vector<double> curve_t, curve_mean, curve_min, curve_max;
};

/// Groups by (mode, robots), coordinated first, then by robot count.
std::vector<ExploreGroup> aggregate(const std::vector<ExploreRun>& runs, double curve_period_s, double until_s);

/// mean time to kExploreLevels[level] of `slow` / that of `fast`; nullopt unless every run of
/// both groups reached it (a mean over the runs that happened to reach it would flatter).
std::optional<double> speedup(const ExploreGroup& slow, const ExploreGroup& fast, std::size_t level);

/// "50" for 0.50 and so on.
std::string level_name(std::size_t level);

}  // namespace cairn::eval
