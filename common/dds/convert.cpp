#include "common/dds/convert.hpp"

#include <algorithm>
#include <cstring>

#include "common/occupancy_grid.hpp"

namespace cairn::dds {

static_assert(cairn_TILE_CELLS == kMapTileSide, "MapTile size: IDL vs common/occupancy_grid.hpp");
static_assert(cairn_MAX_BEAMS == msg::kMaxBeams && cairn_MAX_FEATURES == msg::kMaxFeatures &&
                  cairn_MAX_LANDMARKS == msg::kMaxLandmarks && cairn_MAX_PATH == msg::kMaxPath && cairn_MAX_BIDS == msg::kMaxBids &&
                  cairn_MAX_UNREACHABLE == msg::kMaxUnreachable,
              "common/messages.hpp and common/idl/cairn.idl disagree on a capacity");

namespace {

// The integer in an IDL enum field, whatever a writer put there (C enums are int-sized in
// the generated types). Loading an out-of-range value *as the enum* is undefined.
template <typename E>
int raw_enum(const E& field) {
  static_assert(sizeof(E) == sizeof(int));
  int v = 0;
  std::memcpy(&v, &field, sizeof v);
  return v;
}

// A bounded copy of a text field into a terminated one: an unterminated source is cut at
// the destination's size, never overrun.
void copy_text(const char* from, std::size_t from_size, char* to, std::size_t to_size) {
  std::size_t i = 0;
  for (; i + 1 < to_size && i < from_size && from[i] != '\0'; ++i) to[i] = from[i];
  to[i] = '\0';
}

template <std::size_t N>
void copy_array(const std::array<double, N>& from, double (&to)[N]) {
  std::copy(from.begin(), from.end(), to);
}
template <std::size_t N>
void copy_array(const double (&from)[N], std::array<double, N>* to) {
  std::copy(std::begin(from), std::end(from), to->begin());
}

/// Clamps a received count to the capacity; `ok` turns false when it had to.
template <typename T>
T clamp_count(T n, std::size_t cap, bool* ok) {
  if (static_cast<std::size_t>(n) <= cap) return n;
  *ok = false;
  return static_cast<T>(cap);
}

}  // namespace

void to_dds(const msg::OdometryIncrement& m, cairn_OdometryIncrement* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->t0_ns = m.t0;
  out->t1_ns = m.t1;
  out->delta = to_msg(m.delta);
  copy_array(m.delta_cov, out->delta_cov);
  out->local_pose = to_msg(m.local_pose);
  out->boot_epoch = m.boot_epoch;
}

bool from_dds(const cairn_OdometryIncrement& m, msg::OdometryIncrement* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->t0 = m.t0_ns;
  out->t1 = m.t1_ns;
  out->delta = from_msg(m.delta);
  copy_array(m.delta_cov, &out->delta_cov);
  out->local_pose = from_msg(m.local_pose);
  out->boot_epoch = m.boot_epoch;
  return true;
}

void to_dds(const msg::LaserScan& m, cairn_LaserScan* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp_ns = m.stamp;
  out->angle_min = m.angle_min;
  out->angle_increment = m.angle_increment;
  out->beam_period_s = m.beam_period_s;
  const std::size_t n = std::min<std::size_t>(m.n_beams, msg::kMaxBeams);
  out->n_beams = static_cast<std::uint16_t>(n);
  std::memcpy(out->ranges_mm, m.ranges_mm.data(), n * sizeof(std::uint16_t));
  std::memcpy(out->reflectivity, m.reflectivity.data(), n);
  out->pose = to_msg(m.pose);
  copy_array(m.pose_cov, out->pose_cov);
  out->sensor_offset = to_msg(m.sensor_offset);
}

bool from_dds(const cairn_LaserScan& m, msg::LaserScan* out) {
  bool ok = true;
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp = m.stamp_ns;
  out->angle_min = m.angle_min;
  out->angle_increment = m.angle_increment;
  out->beam_period_s = m.beam_period_s;
  out->n_beams = clamp_count(m.n_beams, msg::kMaxBeams, &ok);
  std::memcpy(out->ranges_mm.data(), m.ranges_mm, out->n_beams * sizeof(std::uint16_t));
  std::memcpy(out->reflectivity.data(), m.reflectivity, out->n_beams);
  out->pose = from_msg(m.pose);
  copy_array(m.pose_cov, &out->pose_cov);
  out->sensor_offset = from_msg(m.sensor_offset);
  return ok;
}

void to_dds(const msg::FeatureObservations& m, cairn_FeatureObservations* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp_ns = m.stamp;
  out->local_pose = to_msg(m.local_pose);
  out->odom_seq = m.odom_seq;
  out->boot_epoch = m.boot_epoch;
  const std::size_t n = std::min<std::size_t>(m.n_features, msg::kMaxFeatures);
  out->n_features = static_cast<std::uint8_t>(n);
  for (std::size_t i = 0; i < n; ++i) {
    const msg::Feature& f = m.features[i];
    cairn_Feature& o = out->features[i];
    o.kind = f.kind == msg::FeatureKind::kRobot ? cairn_FEATURE_ROBOT : cairn_FEATURE_LANDMARK;
    o.marker_id = f.marker_id;
    o.range = f.range;
    o.bearing = f.bearing;
    copy_array(f.cov, o.cov);
  }
}

bool from_dds(const cairn_FeatureObservations& m, msg::FeatureObservations* out) {
  bool ok = true;
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp = m.stamp_ns;
  out->local_pose = from_msg(m.local_pose);
  out->odom_seq = m.odom_seq;
  out->boot_epoch = m.boot_epoch;
  out->n_features = clamp_count(m.n_features, msg::kMaxFeatures, &ok);
  for (std::size_t i = 0; i < out->n_features; ++i) {
    const cairn_Feature& f = m.features[i];
    msg::Feature& o = out->features[i];
    // A hostile writer can put any value in an enum field: read it as the integer it is
    // (loading an out-of-range value as the enum type is undefined behaviour).
    const int kind = raw_enum(f.kind);
    if (kind != cairn_FEATURE_ROBOT && kind != cairn_FEATURE_LANDMARK) ok = false;
    o.kind = kind == cairn_FEATURE_ROBOT ? msg::FeatureKind::kRobot : msg::FeatureKind::kLandmark;
    o.marker_id = f.marker_id;
    o.range = f.range;
    o.bearing = f.bearing;
    copy_array(f.cov, &o.cov);
  }
  return ok;
}

void to_dds(const msg::PoseCorrection& m, cairn_PoseCorrection* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp_ns = m.stamp;
  out->local_to_global = to_msg(m.local_to_global);
  out->global_pose = to_msg(m.global_pose);
  copy_array(m.global_cov, out->global_cov);
}

bool from_dds(const cairn_PoseCorrection& m, msg::PoseCorrection* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->stamp = m.stamp_ns;
  out->local_to_global = from_msg(m.local_to_global);
  out->global_pose = from_msg(m.global_pose);
  copy_array(m.global_cov, &out->global_cov);
  return true;
}

void to_dds(const msg::TaskAssignment& m, cairn_TaskAssignment* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->task_id = m.task_id;
  out->issued_ns = m.issued;
  out->kind = static_cast<cairn_TaskKind>(static_cast<int>(m.kind));
  out->target_x = m.target_x;
  out->target_y = m.target_y;
  const std::size_t n = std::min<std::size_t>(m.n_path, msg::kMaxPath);
  out->n_path = static_cast<std::uint16_t>(n);
  std::copy_n(m.path_xy.begin(), 2 * n, out->path_xy);
}

void to_dds(const msg::SafetyReset& m, cairn_SafetyReset* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued_ns = m.issued;
  copy_text(m.issued_by.data(), m.issued_by.size(), out->issued_by, sizeof out->issued_by);
  out->remote_stops_seen = m.remote_stops_seen;
}

void to_dds(const msg::SafetyStop& m, cairn_SafetyStop* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued_ns = m.issued;
  copy_text(m.issued_by.data(), m.issued_by.size(), out->issued_by, sizeof out->issued_by);
}

void to_dds(const msg::VisitRequest& m, cairn_VisitRequest* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued_ns = m.issued;
  out->x = m.x;
  out->y = m.y;
  copy_text(m.issued_by.data(), m.issued_by.size(), out->issued_by, sizeof out->issued_by);
}

bool from_dds(const cairn_SafetyReset& m, msg::SafetyReset* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued = m.issued_ns;
  copy_text(m.issued_by, sizeof m.issued_by, out->issued_by.data(), out->issued_by.size());
  out->remote_stops_seen = m.remote_stops_seen;
  return true;
}

bool from_dds(const cairn_SafetyStop& m, msg::SafetyStop* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued = m.issued_ns;
  copy_text(m.issued_by, sizeof m.issued_by, out->issued_by.data(), out->issued_by.size());
  return true;
}

bool from_dds(const cairn_VisitRequest& m, msg::VisitRequest* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->issued = m.issued_ns;
  out->x = m.x;  // the executive refuses a non-finite or far target
  out->y = m.y;
  copy_text(m.issued_by, sizeof m.issued_by, out->issued_by.data(), out->issued_by.size());
  return true;
}

bool from_dds(const cairn_TaskAssignment& m, msg::TaskAssignment* out) {
  bool ok = true;
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->task_id = m.task_id;
  out->issued = m.issued_ns;
  const int kind = raw_enum(m.kind);
  if (kind < 0 || kind > static_cast<int>(msg::TaskKind::kStop)) {
    ok = false;
    out->kind = msg::TaskKind::kStop;  // an unknown command stops rather than moves
  } else {
    out->kind = static_cast<msg::TaskKind>(kind);
  }
  out->target_x = m.target_x;
  out->target_y = m.target_y;
  out->n_path = clamp_count(m.n_path, msg::kMaxPath, &ok);
  std::copy_n(m.path_xy, 2 * out->n_path, out->path_xy.begin());
  return ok;
}

void to_dds(const msg::Bid& m, cairn_Bid* out) {
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->map_version = m.map_version;
  const std::size_t n = std::min<std::size_t>(m.n_items, msg::kMaxBids);
  out->n_items = static_cast<std::uint16_t>(n);
  for (std::size_t i = 0; i < n; ++i) {
    const msg::BidItem& a = m.items[i];
    out->items[i] = {a.x, a.y, a.gain, a.cost, a.igr_min_x, a.igr_min_y, a.igr_max_x, a.igr_max_y};
  }
  const std::size_t nu = std::min<std::size_t>(m.n_unreachable, msg::kMaxUnreachable);
  out->n_unreachable = static_cast<std::uint16_t>(nu);
  out->unreachable_dropped = m.unreachable_dropped;
  for (std::size_t i = 0; i < nu; ++i) {
    const msg::UnreachableCluster& u = m.unreachable[i];
    out->unreachable[i] = {u.x, u.y, u.min_x, u.min_y, u.max_x, u.max_y, u.cells, static_cast<std::uint8_t>(u.kind)};
  }
}

// Values are the sender's: the count is clamped here; NaN, negative gains and inverted
// rectangles are the executive's to refuse (TaskAllocator::on_bid, counted).
bool from_dds(const cairn_Bid& m, msg::Bid* out) {
  bool ok = true;
  out->robot_id = m.robot_id;
  out->seq = m.seq;
  out->map_version = m.map_version;
  out->n_items = clamp_count(m.n_items, msg::kMaxBids, &ok);
  for (std::size_t i = 0; i < out->n_items; ++i) {
    const cairn_BidItem& a = m.items[i];
    out->items[i] = {a.x, a.y, a.gain, a.cost, a.igr_min_x, a.igr_min_y, a.igr_max_x, a.igr_max_y};
  }
  // An unknown kind is carried as is (UnreachableKind is an 8-bit enum: every value is
  // representable) and refused by the executive with the rest of the bid.
  out->n_unreachable = clamp_count(m.n_unreachable, msg::kMaxUnreachable, &ok);
  out->unreachable_dropped = m.unreachable_dropped;
  for (std::size_t i = 0; i < out->n_unreachable; ++i) {
    const cairn_UnreachableCluster& u = m.unreachable[i];
    out->unreachable[i] = {u.x, u.y, u.min_x, u.min_y, u.max_x, u.max_y, u.cells, static_cast<msg::UnreachableKind>(u.kind)};
  }
  return ok;
}

void to_dds_page(const msg::Landmark* all, std::size_t count, std::size_t first, std::uint32_t seq, Nanos stamp,
                 cairn_FeatureMap* out) {
  out->robot_id = 0;
  out->page = static_cast<std::uint16_t>(first / msg::kMaxLandmarks);
  out->n_pages = static_cast<std::uint16_t>(feature_map_pages(count));
  out->total = static_cast<std::uint32_t>(count);
  out->seq = seq;
  out->stamp_ns = stamp;
  out->n_landmarks = 0;
  for (std::size_t i = first; i < count && out->n_landmarks < msg::kMaxLandmarks; ++i) {
    cairn_Landmark& l = out->landmarks[out->n_landmarks++];
    l.id = all[i].id;
    l.x = all[i].x;
    l.y = all[i].y;
    copy_array(all[i].cov, l.cov);
  }
}

}  // namespace cairn::dds
