// The base station's fusion: every robot's OdometryIncrement and FeatureObservations
// into one cooperative-CML estimator; PoseCorrection per robot and the FeatureMap out.
// Pure logic on Cairn's own messages (common/messages.hpp: no DDS, no clock), deterministic
// for a given message order, so the state store can rebuild it exactly from a snapshot and
// a log. The DDS edge (fusion_node.cpp) converts to and from the IDL structs.
//
// Ordering rules: odometry is applied in seq order per robot (duplicates skipped; a gap
// is bridged with the robot's reported local poses, its covariance scaled by the gap).
// Features wait (bounded, per robot) until the odometry they refer to (odom_seq) has been
// applied. Features that arrive after later odometry (the two topics are independent) are
// re-expressed from the robot's current pose through the robot's own local poses, with
// the odometry covariance in between added to their noise; only features older than the
// remembered odometry window are stale (counted, not applied).
//
// Robustness (docs/ccml.md, "The base's fusion"): every message is checked (fusion_checks)
// and everything refused is counted by reason (reject.hpp), never thrown. Only configured
// robots join unless unknown ones are allowed (bounded); the map frame is the configured
// robots' priors, never whoever speaks first. A new boot_epoch is a robot restart (new
// local frame, inflated covariance), a retired one is stale. New landmarks stay tentative
// until seen often enough and the map is capped. Relocation needs an unambiguous,
// complete JCBB search.
#pragma once

#include <cstdint>
#include <deque>
#include <iosfwd>
#include <map>
#include <optional>
#include <vector>

#include "basestation/ccml/filter.hpp"
#include "basestation/ccml/jcbb.hpp"
#include "basestation/fusion_checks.hpp"
#include "basestation/reject.hpp"
#include "common/clock.hpp"
#include "common/messages.hpp"

namespace cairn::base {

struct RobotPrior {
  bool known = false;  // false: pose unknown, joins by relocation against the map
  Pose2 pose;          // global pose of the robot's local origin
  Vec3 sigma = Vec3(100, 100, 3.0);
};

struct FusionConfig {
  std::map<std::uint16_t, RobotPrior> robots;  // the fleet, with priors; the known ones define the map frame
  RobotPrior unknown;                          // for robots not listed (never known)
  bool allow_unknown_robots = false;           // else robots not listed are refused
  std::size_t max_unknown_robots = 8;          // at most this many unlisted robots join
  int iterations = 1;                          // EKF update iterations
  ccml::CovarianceUpdate covariance_update = ccml::CovarianceUpdate::kSymmetric;  // kJoseph: the old, ~4× dearer form
  std::size_t max_pending = 64;                // feature messages waiting for their odometry, per robot
  std::size_t odometry_window = 1024;          // increments remembered per robot to re-express late features
  double candidate_range = 15.0;               // JCBB candidates within this distance (m)
  bool robot_observations = true;              // fuse robots' sightings of each other (off: each robot alone)
  /// An unpaired observation starts a new feature only if no existing feature explains it
  /// even at this confidence (far stricter than the pairing gate: duplicates are costly).
  double new_feature_confidence = 0.999999;
  std::size_t max_landmarks = 2000;            // new landmarks beyond this are refused (counted)
  std::uint32_t landmark_confirm_count = 3;    // a new landmark seen fewer times than this ...
  std::uint64_t landmark_confirm_age = 100;    // ... within this many feature messages (all robots) is removed
  Vec3 restart_sigma = Vec3(0.2, 0.2, 0.05);   // added to a rebooted robot's pose (x m, y m, θ rad)
  FusionLimits limits;
  ccml::JcbbConfig jcbb;
};

struct FusionCounters {
  std::uint64_t odometry_applied = 0, odometry_duplicates = 0, odometry_gaps = 0;
  std::uint64_t feature_messages_applied = 0, feature_duplicates = 0, feature_late = 0, feature_stale = 0, pending_overflow = 0;
  std::uint64_t observations_used = 0, observations_new_features = 0, landmarks_pruned = 0;
  std::uint64_t robots_joined = 0, robots_localized = 0, robots_restarted = 0;
  // Robots seen by robots: all sightings, those whose marker was not read, and those that
  // entered an applied update.
  // Unread ones are paired by JCBB among the robots (jcbb_robots), or not at all.
  std::uint64_t robot_sightings = 0, robot_sightings_unidentified = 0, robot_observations_used = 0;
  std::uint64_t robot_sightings_paired = 0, robot_sightings_unpaired = 0;
  // Normalised innovation squared of the observations that passed the gate, summed by kind
  // (landmark, robot): with the stated covariances right, each mean is about 2 (the gate
  // cuts its tail). Far below 2, the covariances claim too little; far above, too much.
  double nis_sum_landmark = 0, nis_sum_robot = 0;
  std::uint64_t nis_count_landmark = 0, nis_count_robot = 0;
  RejectCounters rejected;  // by reason: messages and observations not applied
};

class Fusion {
 public:
  enum class Result { kApplied, kDuplicate, kBuffered, kRejected };

  explicit Fusion(FusionConfig config);

  Result on_odometry(const msg::OdometryIncrement& m);
  Result on_features(const msg::FeatureObservations& m);

  /// The correction for one robot; false if the robot is unknown or not yet localised.
  bool correction(std::uint16_t robot, Nanos stamp, msg::PoseCorrection* out) const;
  /// When, on the robot's clock, the pose a correction is computed at holds, and which
  /// local frame it is of.
  struct EstimateClock {
    Nanos t = 0;                   // t1 of the robot's latest applied odometry
    std::uint32_t boot_epoch = 0;  // the robot's current boot: its local frame
    Nanos boot_t0 = 0;             // t1 of the first odometry applied in this boot
  };
  /// False for a robot without odometry in its current boot (just restarted: its
  /// correction is still the old local frame's).
  bool estimate_clock(std::uint16_t robot, EstimateClock* out) const;
  std::vector<std::uint16_t> robots() const;
  /// Every landmark of the map (all of them: the DDS edge pages them), into a caller's buffer.
  void landmarks(std::vector<msg::Landmark>* out) const;
  const ccml::CcmlFilter& filter() const { return filter_; }
  const FusionCounters& counters() const { return counters_; }
  bool localized(std::uint16_t robot) const;
  /// How far the base has come with one robot's streams in its current boot: the last
  /// odometry and feature seq applied (the robot numbers each stream from 1 per boot).
  struct RobotProgress {
    std::uint32_t boot_epoch = 0, odom_seq = 0, feature_seq = 0;
    bool localized = false;
  };
  std::optional<RobotProgress> progress(std::uint16_t robot) const;
  /// The robot passed admission (listed, or an unknown robot within the cap).
  bool admitted(std::uint16_t robot) const { return tracks_.contains(robot); }
  /// Every number of the joint state (mean and covariance) is finite.
  bool finite() const { return filter_.mean().allFinite() && filter_.covariance().allFinite(); }

  /// The message checks alone (no state change): the DDS node runs them before logging.
  std::optional<Reject> check(const msg::OdometryIncrement& m) const { return base::check(m, config_.limits); }
  std::optional<Reject> check(const msg::FeatureObservations& m) const { return base::check(m, config_.limits); }
  /// Counts a refusal decided outside (a malformed DDS sample, a message that threw).
  void count(Reject r) { counters_.rejected.count(r); }

  /// Exact binary snapshot (estimator, per-robot bookkeeping, waiting messages, counters).
  void save(std::ostream& out) const;
  void load(std::istream& in);

 private:
  struct Track {
    bool joined = false;  // in the estimator (on its first odometry)
    bool have_odometry = false;
    std::uint32_t odom_seq = 0;
    Pose2 local;  // robot's local pose at odom_seq
    Nanos local_t = 0;  // its time (t1), the robot's clock
    Nanos boot_t0 = 0;  // t1 of this boot's first odometry
    // (Neither time is in the saved state: after a restore both are 0 until the robot's
    // next odometry, which only the mapper's frame history reads, and it starts empty.)
    bool have_features = false;
    std::uint32_t feature_seq = 0;
    bool localized = false;
    std::deque<msg::FeatureObservations> pending;
    // Cumulative odometry covariance (robot frame approximation) by seq, for late features.
    std::deque<std::pair<std::uint32_t, Mat3>> cumulative;
    bool have_epoch = false;
    std::uint32_t epoch = 0;
    std::deque<std::uint32_t> retired;  // epochs the robot has left (bounded)
  };
  struct Tentative {  // a new landmark not yet confirmed
    std::uint32_t seen = 1;
    std::uint64_t born = 0;  // feature_messages_applied when it was added
  };
  enum class Epoch { kCurrent, kRestarted, kStale };

  /// The robot's track if it may send (listed, or unknown ones allowed and room); else the reason.
  Track* admit(std::uint16_t robot, Reject* why);
  Epoch epoch(std::uint16_t robot, Track& t, std::uint32_t e);
  Track& join(std::uint16_t robot, Track& t, const Pose2& local_now);
  void prune_tentative();
  void apply_features(const msg::FeatureObservations& m, Track& t);
  struct UnreadSighting {  // a robot seen without its id
    RangeBearing z;
    Mat2 R;
  };
  /// Pairs the unread sightings with robots by JCBB among robots (uncontested pairings only), into `batch`.
  void pair_unread_robots(ccml::RobotId me, const std::vector<UnreadSighting>& unread, std::vector<ccml::Measurement>* batch);
  void remember(Track& t, const Mat3& cov);
  /// Re-expresses a late message's features from the robot's current pose; false if too old.
  bool reexpress(msg::FeatureObservations* m, const Track& t) const;
  void drain_pending(std::uint16_t robot, Track& t);

  FusionConfig config_;
  ccml::CcmlFilter filter_;
  std::map<std::uint16_t, Track> tracks_;
  std::map<ccml::FeatureId, Tentative> tentative_;
  FusionCounters counters_;
};

}  // namespace cairn::base
