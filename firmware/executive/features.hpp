// Retroreflective features from one laser scan. The scan is cut into clusters of
// neighbouring beams with continuous range (one surface each). A cluster with flagged
// beams that fits a circle of the fleet's body radius is another robot: observed at its
// centre, with the id its coded marker says (firmware/executive/marker_decoder.hpp), or
// -1 when the code cannot be read. Any other cluster that is flagged from end to end is a
// feature: a narrow one a pole (landmark; its centre is one pole radius behind the
// surface), a wide one a robot's marker without identity; tape with bare surface beside it
// is part of a body seen in part, and left out. Output in the robot frame (the
// laser's mount applied) as range and bearing with a 2×2 covariance. Pure; a
// fixed-capacity output in beam order, extra features counted; work linear in the beams.
#pragma once

#include <array>
#include <cstdint>

#include "common/se2.hpp"
#include "drivers/sick/lms_driver.hpp"

namespace cairn::firmware {

inline constexpr std::size_t kMaxScanFeatures = 32;  // = MAX_FEATURES in the IDL

struct FeatureConfig {
  double pole_radius_m = 0.05;
  double robot_marker_min_width_m = 0.25;  // a run (or a body seen) at least this wide is a robot
  double robot_radius_m = 0.3;             // every robot's body (where its marker is taped)
  double body_fit_rms_m = 0.02;            // a body's points lie this close to its circle
  double marker_margin_rad = 0.05;         // error in placing a beam round a body (docs/markers.md)
  std::size_t marker_min_beams = 6;        // a code is read from at least this many beams on the body
  double max_width_m = 1.0;                // wider: not a marker (a reflective wall)
  double max_range_step_m = 0.15;          // range jump that splits a run
  double sigma_range_m = 0.03;     // measured on the HIL bench incl. pose error (docs/firmware.md)
  double sigma_bearing_rad = 0.01;
  // A fitted body's centre has the fit's own covariance s²(JᵀJ)⁻¹, s the points' scatter
  // round the circle but at least body_sigma_floor_m (the range readings' 1 mm resolution:
  // the scanner's 5 mm range noise is no floor, a beam meeting the body at a slant scatters
  // less than that across it, and that floor overstated the covariance 1.7x), plus
  // body_sigma_motion_m² in each direction: the seen robot moves during the sweep, and the
  // base holds its pose at its own latest odometry, up to a scan period away.
  double body_sigma_floor_m = 0.001;
  double body_sigma_motion_m = 0.01;
  double max_range_m = 30.0;
};

struct ScanFeature {
  bool robot = false;
  int marker_id = -1;              // a robot's decoded id, -1 unknown
  double range = 0, bearing = 0;   // robot frame
  Mat2 covariance = Mat2::Zero();  // (range, bearing)
  double width = 0;
  std::uint16_t first_beam = 0, last_beam = 0;  // the beams it was seen on
};

struct ScanFeatures {
  std::array<ScanFeature, kMaxScanFeatures> items{};
  std::size_t count = 0;
  std::uint32_t dropped = 0;  // beyond capacity
};

void extract_features(const lms::LmsScan& scan, const Pose2& mount, const FeatureConfig& cfg, ScanFeatures* out);

}  // namespace cairn::firmware
