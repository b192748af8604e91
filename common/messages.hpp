// Cairn's own message types: what the robot pipeline emits and the base station's
// fusion, mapper and executive consume. They mirror the DDS topics of common/idl/cairn.idl
// but carry no transport: the robot executive, the base's fusion and cairn-sim speak these,
// and one conversion unit (common/dds/convert.hpp) maps them to and from the IDL structs
// at each edge. Every message is trivially copyable and of fixed size (arrays + counts),
// so it goes through an SPSC queue, a log record or a snapshot as plain bytes, and the
// robot never allocates to fill one.
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>

#include "common/clock.hpp"
#include "common/se2.hpp"

namespace cairn::msg {

// Capacities: the IDL's constants must equal these (common/dds/convert.cpp checks it).
constexpr std::size_t kMaxBeams = 721;      // LMS2xx 180 deg at 0.25 deg
constexpr std::size_t kMaxFeatures = 32;    // per FeatureObservations
constexpr std::size_t kMaxLandmarks = 128;  // per FeatureMap page
constexpr std::size_t kMaxPath = 64;        // waypoints in a TaskAssignment
constexpr std::size_t kMaxBids = 48;        // frontier items per Bid (IDL MAX_BIDS)
constexpr std::size_t kMaxUnreachable = 16; // unreachable frontier clusters per Bid (IDL MAX_UNREACHABLE)

/// Row-major 3x3 / 2x2 covariances as plain arrays (Eigen types are not trivially copyable).
using Cov3 = std::array<double, 9>;
using Cov2 = std::array<double, 4>;

inline Mat3 to_mat(const Cov3& c) {
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) m(r, k) = c[static_cast<std::size_t>(r * 3 + k)];
  return m;
}
inline Mat2 to_mat(const Cov2& c) {
  Mat2 m;
  m << c[0], c[1], c[2], c[3];
  return m;
}
inline Cov3 to_cov(const Mat3& m) {
  Cov3 c;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) c[static_cast<std::size_t>(r * 3 + k)] = m(r, k);
  return c;
}
inline Cov2 to_cov(const Mat2& m) { return {m(0, 0), m(0, 1), m(1, 0), m(1, 1)}; }

/// Motion between two instants in the robot frame at t0 (scan-matched), and the robot's
/// corrected local pose at t1.
struct OdometryIncrement {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos t0 = 0, t1 = 0;
  Pose2 delta;
  Cov3 delta_cov{};
  Pose2 local_pose;
  /// Chosen once at each start of the robot process (its boot time or a random number); its
  /// seq and local frame restart with it. The base treats a new epoch as a restart and a
  /// retired one as stale. 0 = not set (a robot that predates epochs).
  std::uint32_t boot_epoch = 0;
  friend bool operator==(const OdometryIncrement&, const OdometryIncrement&) = default;
};

/// One laser scan with the corrected local pose of the sensor at its first beam.
struct LaserScan {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos stamp = 0;  // time of the first beam
  float angle_min = 0, angle_increment = 0, beam_period_s = 0;
  std::uint16_t n_beams = 0;
  std::array<std::uint16_t, kMaxBeams> ranges_mm{};  // 0 = no return
  std::array<std::uint8_t, kMaxBeams> reflectivity{};
  Pose2 pose;  // sensor, local frame
  Cov3 pose_cov{};
  Pose2 sensor_offset;  // laser in the robot frame
  friend bool operator==(const LaserScan&, const LaserScan&) = default;
};

enum class FeatureKind : std::uint8_t { kLandmark = 0, kRobot = 1 };

struct Feature {
  FeatureKind kind = FeatureKind::kLandmark;
  std::int32_t marker_id = -1;  // robot id of a decoded robot marker, else -1
  double range = 0, bearing = 0;
  Cov2 cov{};  // (range, bearing)
  friend bool operator==(const Feature&, const Feature&) = default;
};

struct FeatureObservations {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos stamp = 0;
  Pose2 local_pose;
  std::uint32_t odom_seq = 0;  // last OdometryIncrement folded into local_pose
  std::uint32_t boot_epoch = 0;  // as OdometryIncrement::boot_epoch
  std::uint8_t n_features = 0;
  std::array<Feature, kMaxFeatures> features{};
  friend bool operator==(const FeatureObservations&, const FeatureObservations&) = default;
};

/// The base's estimate for one robot: global = local_to_global ⊕ local.
struct PoseCorrection {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos stamp = 0;
  Pose2 local_to_global;
  Pose2 global_pose;
  Cov3 global_cov{};
  friend bool operator==(const PoseCorrection&, const PoseCorrection&) = default;
};

enum class TaskKind : std::uint8_t { kIdle = 0, kExplore = 1, kGoto = 2, kStop = 3 };
/// The kinds that send the robot somewhere (a target to plan to).
constexpr bool task_moves(TaskKind k) { return k == TaskKind::kExplore || k == TaskKind::kGoto; }

struct TaskAssignment {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0, task_id = 0;
  Nanos issued = 0;
  TaskKind kind = TaskKind::kIdle;
  double target_x = 0, target_y = 0;  // global frame
  std::uint16_t n_path = 0;
  std::array<double, 2 * kMaxPath> path_xy{};  // global frame, x0 y0 x1 y1 ...
  friend bool operator==(const TaskAssignment&, const TaskAssignment&) = default;
};

/// One frontier a robot offers to explore (global frame): the cell, its expected
/// information gain (unknown cells it may reveal) and the robot's path cost to it, and the
/// bounding rectangle of its information-gain region (IGR) for the executive's discount.
struct BidItem {
  double x = 0, y = 0;
  double gain = 0;  // cells
  double cost = 0;  // m
  double igr_min_x = 0, igr_min_y = 0, igr_max_x = 0, igr_max_y = 0;
  friend bool operator==(const BidItem&, const BidItem&) = default;
};

/// Why a robot cannot reach a stretch of frontier (docs/explore.md, "Unreachable frontiers").
enum class UnreachableKind : std::uint8_t {
  kTooNarrow = 0,     // connected to the robot through known clear space, but only through gaps its disc does not fit
  kDisconnected = 1,  // not connected through known clear space at all (seen through a window, over an obstacle)
};
constexpr bool valid(UnreachableKind k) { return k == UnreachableKind::kTooNarrow || k == UnreachableKind::kDisconnected; }

/// A connected stretch of frontier cells the robot cannot reach with its footprint (global
/// frame): the centroid of the cells' centres, their bounding rectangle on cell edges, how
/// many cells, and why.
struct UnreachableCluster {
  double x = 0, y = 0;
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  std::uint32_t cells = 0;
  UnreachableKind kind = UnreachableKind::kTooNarrow;
  friend bool operator==(const UnreachableCluster&, const UnreachableCluster&) = default;
};

/// A robot's best frontier items after a map update (robot -> base).
struct Bid {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  std::uint32_t map_version = 0;  // the map the items were computed on
  std::uint16_t n_items = 0;
  std::array<BidItem, kMaxBids> items{};
  // The frontier it cannot reach, the largest clusters first; clusters beyond
  // kMaxUnreachable are counted in unreachable_dropped, not sent.
  std::uint16_t n_unreachable = 0;
  std::uint32_t unreachable_dropped = 0;
  std::array<UnreachableCluster, kMaxUnreachable> unreachable{};
  friend bool operator==(const Bid&, const Bid&) = default;
};

/// An operator's explicit e-stop reset for one robot (the robot's e-stop latches).
struct SafetyReset {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos issued = 0;
  std::array<char, 32> issued_by{};  // terminated
  std::uint32_t remote_stops_seen = 0;  // the robot's remote-stop count the operator saw (RobotStatus.remote_stops)
};

/// An operator's remote e-stop (robot_id 0: every robot); the robot latches until a reset.
struct SafetyStop {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos issued = 0;
  std::array<char, 32> issued_by{};  // terminated
};

/// An operator's request that one robot visit a place (tool or web view -> base).
struct VisitRequest {
  std::uint16_t robot_id = 0;
  std::uint32_t seq = 0;
  Nanos issued = 0;
  double x = 0, y = 0;               // global frame
  std::array<char, 32> issued_by{};  // terminated
};

struct Landmark {
  std::uint32_t id = 0;
  double x = 0, y = 0;
  Cov2 cov{};
};

static_assert(std::is_trivially_copyable_v<OdometryIncrement> && std::is_trivially_copyable_v<LaserScan> &&
              std::is_trivially_copyable_v<FeatureObservations> && std::is_trivially_copyable_v<PoseCorrection> &&
              std::is_trivially_copyable_v<TaskAssignment> && std::is_trivially_copyable_v<SafetyReset> &&
              std::is_trivially_copyable_v<SafetyStop> &&
              std::is_trivially_copyable_v<Landmark> && std::is_trivially_copyable_v<Bid> &&
              std::is_trivially_copyable_v<VisitRequest>);

}  // namespace cairn::msg
