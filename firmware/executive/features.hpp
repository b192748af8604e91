// Retroreflective features from one laser scan: runs of consecutive beams with the LMS
// reflector flag and continuous range become one feature; a narrow run is a pole
// (landmark; its centre is one pole radius behind the surface), a wide one another
// robot's marker. Output in the robot frame (the laser's mount applied) as range and
// bearing with a 2×2 covariance. Pure; a fixed-capacity output, extra features counted.
#pragma once

#include <array>
#include <cstdint>

#include "common/se2.hpp"
#include "drivers/sick/lms_driver.hpp"

namespace cairn::firmware {

inline constexpr std::size_t kMaxScanFeatures = 32;  // = MAX_FEATURES in the IDL

struct FeatureConfig {
  double pole_radius_m = 0.05;
  double robot_marker_min_width_m = 0.25;  // a run at least this wide is a robot's marker
  double max_width_m = 1.0;                // wider: not a marker (a reflective wall)
  double max_range_step_m = 0.15;          // range jump that splits a run
  double sigma_range_m = 0.03;     // measured on the HIL bench incl. pose error (docs/firmware.md)
  double sigma_bearing_rad = 0.01;
  double max_range_m = 30.0;
};

struct ScanFeature {
  bool robot = false;
  double range = 0, bearing = 0;   // robot frame
  Mat2 covariance = Mat2::Zero();  // (range, bearing)
  double width = 0;
};

struct ScanFeatures {
  std::array<ScanFeature, kMaxScanFeatures> items{};
  std::size_t count = 0;
  std::uint32_t dropped = 0;  // beyond capacity
};

void extract_features(const lms::LmsScan& scan, const Pose2& mount, const FeatureConfig& cfg, ScanFeatures* out);

}  // namespace cairn::firmware
