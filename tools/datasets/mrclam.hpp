// The UTIAS Multi-Robot Cooperative Localization and Mapping dataset (Leung et al.,
// IJRR 2011): reader and the three estimators the evaluation compares —
// dead reckoning, one single-robot EKF-SLAM per robot, and cooperative CML over all
// five robots with robot-robot observations — with landmark association either by
// the barcode labels or by JCBB (robots are identified by their markers in both).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "basestation/ccml/filter.hpp"

namespace cairn::ccml {

struct MrclamOdometry {
  double t, v, w;
};
struct MrclamMeasurement {
  double t;
  int subject;  // 1-5 robots, 6-20 landmarks (mapped from the barcode)
  double range, bearing;
};
struct MrclamPose {
  double t, x, y, theta;
};

struct MrclamRobotData {
  std::vector<MrclamOdometry> odometry;
  std::vector<MrclamMeasurement> measurements;
  std::vector<MrclamPose> groundtruth;  // empty when missing (Dataset 1)
};

struct MrclamData {
  std::string dir;
  std::map<int, Vec2> landmarks;            // subject -> ground-truth position
  std::vector<MrclamRobotData> robots;      // index 0 = robot 1
  std::size_t unknown_barcodes_dropped = 0;
  bool has_robot_groundtruth() const;
};

/// Reads a dataset directory; throws std::runtime_error naming the file on a problem.
MrclamData load_mrclam(const std::string& dir);

struct MrclamOptions {
  enum class Mode { kDeadReckoning, kSingleRobot, kCooperative };
  enum class Association { kLabels, kJcbb };
  Mode mode = Mode::kCooperative;
  Association association = Association::kLabels;
  double range_sigma = 0.15;        // m
  double bearing_sigma = 0.06;      // rad
  double odom_v_rel = 0.15;         // σ of travelled distance, fraction of it
  double odom_w_rel = 0.4;          // σ of turned angle, fraction of it
  double odom_v_rate = 0.03;        // m/√s floor
  double odom_w_rate = 0.15;        // rad/√s floor
  double initial_sigma_xy = 0.02;   // when initial poses come from ground truth
  double initial_sigma_theta = 0.02;
  double outlier_confidence = 0.999;  // individual gate for labelled measurements
  double max_range = 8.0;           // JCBB candidates: predicted range below this
  int iterations = 1;               // EKF update iterations
  double duration = 0;              // seconds from the start (0 = all)
  double score_from = 0;            // score (RMSE, NEES) only from this many seconds after the start
};

/// The odometry covariance the runs add for one step of commanded (v, w) over dt.
Mat3 mrclam_odometry_cov(const MrclamOptions& o, double v, double w, double dt);
/// Ground truth linearly interpolated at t (nullopt outside it); `hint` speeds up increasing t.
std::optional<Pose2> interpolate_groundtruth(const std::vector<MrclamPose>& gt, double t, std::size_t* hint);
/// The runs' start: the earliest ground-truth sample, else the earliest odometry.
double mrclam_start(const MrclamData& d);
/// The runs' end: the earliest last ground-truth sample (else last odometry), cut to `o.duration`.
double mrclam_end(const MrclamData& d, const MrclamOptions& o);

struct MrclamRobotResult {
  int robot = 0;
  std::size_t samples = 0;
  double rmse_xy = -1;           // m, vs ground truth (-1 when not available)
  double nees_mean = -1;         // pose NEES (3 dof) over the run
  bool localized = false;        // (relocation runs) joined the map
  double localized_at = -1;      // s from the start
};

struct MrclamResult {
  std::string mode, association;
  std::vector<MrclamRobotResult> robots;
  double rmse_xy_mean = -1;       // mean over robots with ground truth
  // Landmarks: estimated features matched to ground truth (by label, or by the majority
  // label of the observations JCBB associated with each feature).
  std::size_t features = 0;
  std::size_t landmarks_matched = 0;
  double landmark_rmse_unaligned = -1;
  double landmark_rmse_aligned = -1;
  Pose2 alignment;                // least-squares SE(2) from the estimated map to ground truth
  std::vector<std::pair<int, Vec2>> map;  // (label, estimated position) of the matched features (first map)
  // Label-free check of the map: multi-start ICP of the estimated features onto the
  // ground-truth landmarks (nearest neighbour). Exposes labelling defects in the data.
  double landmark_rmse_label_free = -1;
  std::vector<std::pair<int, int>> label_mismatches;  // (label, ground-truth landmark it lands on)
  std::size_t measurements_used = 0, measurements_rejected = 0, association_errors = 0;
  bool association_errors_known = true;  // false when the estimator never saw the labels (base-fusion)
  std::size_t unknown_barcodes_dropped = 0;
  double runtime_s = 0;
  double duration_s = 0;
};

MrclamResult run_mrclam(const MrclamData& data, const MrclamOptions& options);

/// Multi-start ICP of `est` onto `gt` by nearest neighbour: the RMSE and, per est point,
/// the index of its gt point; -1 (and `nearest` untouched) with fewer than 2 points.
double label_free_fit(const std::vector<Vec2>& est, const std::vector<Vec2>& gt, std::vector<int>* nearest);

const char* mode_name(MrclamOptions::Mode m);
const char* association_name(MrclamOptions::Association a);

}  // namespace cairn::ccml
