// Robot trajectories (the base's trajectories.csv, in robot time) against the HIL bench's
// ground truth (cairn-hil --truth FILE): position RMSE per robot after interpolating the
// truth at each estimate's time. Both clocks are CLOCK_MONOTONIC of one machine; the
// truth file's `# t0_monotonic_ns` line places its t_s = 0 on it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "basestation/mapper/export.hpp"

namespace cairn::tools {

struct GroundTruth {
  Nanos t0 = 0;  // CLOCK_MONOTONIC at t_s = 0
  struct Sample {
    double t_s = 0;
    Pose2 pose;
  };
  std::map<std::uint16_t, std::vector<Sample>> robots;  // each in time order
};

/// Reads cairn-hil's truth file (`t_s robot x y theta odometer_m` lines, `#` comments, one
/// of them `# t0_monotonic_ns N`); throws std::runtime_error naming the file and the line.
GroundTruth read_ground_truth(const std::string& path);
GroundTruth parse_ground_truth(std::string_view text, const std::string& name);

struct RobotPoseQuality {
  std::uint16_t robot = 0;
  std::size_t samples = 0;  // estimates scored
  std::size_t unscored = 0;  // outside the truth's time span, or no truth within 0.5 s
  double rmse_m = 0, max_m = 0, heading_rmse_rad = 0;
};

struct PoseQuality {
  std::vector<RobotPoseQuality> robots;  // by id
  std::size_t samples = 0;
  double rmse_m = 0, max_m = 0;  // over every scored estimate
};

/// Each estimate against the truth interpolated at its time (linear in position, shortest
/// way in heading) between two truth samples at most 0.5 s apart.
PoseQuality evaluate_poses(const std::vector<mapper::TrajectorySample>& estimates, const GroundTruth& truth);

std::string to_text(const PoseQuality& q);

}  // namespace cairn::tools
