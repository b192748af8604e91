#include "basestation/fusion.hpp"

#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>


namespace cairn::base {

using ccml::Measurement;

Fusion::Fusion(FusionConfig config) : config_(std::move(config)) {}

namespace {
bool finite_pose(const Pose2& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta); }
template <std::size_t N>
bool finite_all(const std::array<double, N>& a) {
  for (double v : a) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}
Mat3 mat3(const msg::Cov3& a) { return msg::to_mat(a); }
Mat2 mat2(const msg::Cov2& a) { return msg::to_mat(a); }
}  // namespace

bool Fusion::valid(const msg::OdometryIncrement& m) {
  if (!finite_pose(m.delta) || !finite_pose(m.local_pose) || !finite_all(m.delta_cov)) return false;
  const Mat3 c = mat3(m.delta_cov);
  return c.diagonal().minCoeff() >= 0 && (c - c.transpose()).cwiseAbs().maxCoeff() < 1e-9;
}

bool Fusion::valid(const msg::FeatureObservations& m) {
  if (!finite_pose(m.local_pose) || m.n_features > msg::kMaxFeatures) return false;
  for (std::size_t i = 0; i < m.n_features; ++i) {
    const msg::Feature& f = m.features[i];
    if (!std::isfinite(f.range) || !std::isfinite(f.bearing) || f.range <= 0 || !finite_all(f.cov)) return false;
    const Mat2 c = mat2(f.cov);
    if (c(0, 0) <= 0 || c(1, 1) <= 0 || c.determinant() <= 0) return false;
  }
  return true;
}

Fusion::Track& Fusion::join(std::uint16_t robot, const Pose2& local_now) {
  Track& t = tracks_[robot];
  if (t.joined) return t;
  auto p = config_.robots.find(robot);
  RobotPrior prior = p != config_.robots.end() ? p->second : config_.unknown;
  // The first robot into an empty map defines the map frame, whatever its prior says.
  const bool first = filter_.robot_ids().empty() && filter_.feature_count() == 0;
  if (!prior.known && first) prior.known = true;
  const Mat3 cov = prior.sigma.cwiseAbs2().asDiagonal();
  filter_.add_robot(robot, compose(prior.pose, local_now), cov);
  t.joined = true;
  t.localized = prior.known;
  ++counters_.robots_joined;
  if (prior.known) ++counters_.robots_localized;
  return t;
}

Fusion::Result Fusion::on_odometry(const msg::OdometryIncrement& m) {
  if (!valid(m)) {
    ++counters_.invalid_messages;
    return Result::kRejected;
  }
  const Pose2 local = m.local_pose;
  Track& t = join(m.robot_id, local);
  if (!t.have_odometry) {
    // First increment: join() placed the robot at prior ⊕ this local pose; nothing to predict.
    t.have_odometry = true;
    t.odom_seq = m.seq;
    t.local = local;
    remember(t, Mat3::Zero());
    ++counters_.odometry_applied;
    drain_pending(m.robot_id, t);
    return Result::kApplied;
  }
  if (m.seq <= t.odom_seq) {
    ++counters_.odometry_duplicates;
    return Result::kDuplicate;
  }
  Pose2 delta = m.delta;
  Mat3 cov = mat3(m.delta_cov);
  if (m.seq != t.odom_seq + 1) {
    // Missed increments: bridge with the robot's own local poses, uncertainty scaled by the gap.
    ++counters_.odometry_gaps;
    delta = between(t.local, local);
    cov *= static_cast<double>(m.seq - t.odom_seq);
  }
  filter_.predict(m.robot_id, delta, cov);
  t.odom_seq = m.seq;
  t.local = local;
  remember(t, cov);
  ++counters_.odometry_applied;
  drain_pending(m.robot_id, t);
  return Result::kApplied;
}

Fusion::Result Fusion::on_features(const msg::FeatureObservations& m) {
  if (!valid(m)) {
    ++counters_.invalid_messages;
    return Result::kRejected;
  }
  auto it = tracks_.find(m.robot_id);
  if (it != tracks_.end() && it->second.have_features && m.seq <= it->second.feature_seq) {
    ++counters_.feature_duplicates;
    return Result::kDuplicate;
  }
  if (it == tracks_.end() || !it->second.have_odometry || m.odom_seq > it->second.odom_seq) {
    Track& track = tracks_[m.robot_id];  // waits here until the robot's odometry catches up
    for (const auto& p : track.pending) {
      if (p.seq == m.seq) {
        ++counters_.feature_duplicates;
        return Result::kDuplicate;
      }
    }
    if (track.pending.size() >= config_.max_pending) {
      track.pending.pop_front();
      ++counters_.pending_overflow;
    }
    track.pending.push_back(m);
    return Result::kBuffered;
  }
  Track& t = it->second;
  if (m.odom_seq < t.odom_seq) {
    msg::FeatureObservations late = m;
    if (!reexpress(&late, t)) {
      ++counters_.feature_stale;
      return Result::kRejected;
    }
    ++counters_.feature_late;
    apply_features(late, t);
    return Result::kApplied;
  }
  apply_features(m, t);
  return Result::kApplied;
}

void Fusion::drain_pending(std::uint16_t robot, Track& t) {
  (void)robot;
  while (!t.pending.empty() && t.pending.front().odom_seq <= t.odom_seq) {
    const msg::FeatureObservations m = t.pending.front();
    t.pending.pop_front();
    if (t.have_features && m.seq <= t.feature_seq) {
      ++counters_.feature_duplicates;
    } else {
      apply_features(m, t);  // odom_seq <= t.odom_seq here; equal unless several were released at once
    }
  }
}

void Fusion::remember(Track& t, const Mat3& cov) {
  const Mat3 total = t.cumulative.empty() ? cov : Mat3(t.cumulative.back().second + cov);
  t.cumulative.emplace_back(t.odom_seq, total);
  while (t.cumulative.size() > config_.odometry_window) t.cumulative.pop_front();
}

bool Fusion::reexpress(msg::FeatureObservations* m, const Track& t) const {
  auto at = [&](std::uint32_t seq) -> const Mat3* {
    for (auto it = t.cumulative.rbegin(); it != t.cumulative.rend(); ++it) {
      if (it->first == seq) return &it->second;
      if (it->first < seq) break;
    }
    return nullptr;
  };
  const Mat3* then = at(m->odom_seq);
  if (!then || t.cumulative.empty()) return false;
  const Mat3 motion = t.cumulative.back().second - *then;  // odometry covariance accumulated since
  // T: the frame the features were observed in, seen from the robot's current local pose.
  const Pose2 T = between(t.local, m->local_pose);
  for (std::size_t i = 0; i < m->n_features; ++i) {
    msg::Feature& f = m->features[i];
    const RangeBearing z{f.range, f.bearing};
    const Vec2 p = point_from_observation({}, z);
    const Vec2 q = transform_point(T, p);
    Mat2 g_z, h_q;
    point_from_observation_jacobians({}, z, nullptr, &g_z);
    Mat23 j_T;
    Mat2 j_p;
    transform_point_jacobians(T, p, &j_T, &j_p);
    observe_point_jacobians({}, q, nullptr, &h_q);
    const Mat2 R = mat2(f.cov);
    const Mat2 Rq = j_p * g_z * R * g_z.transpose() * j_p.transpose() + j_T * motion * j_T.transpose();
    const Mat2 Rz = h_q * Rq * h_q.transpose();
    const RangeBearing z2 = observe_point({}, q);
    f.range = z2.range;
    f.bearing = z2.bearing;
    f.cov[0] = Rz(0, 0);
    f.cov[1] = f.cov[2] = 0.5 * (Rz(0, 1) + Rz(1, 0));
    f.cov[3] = Rz(1, 1);
  }
  m->local_pose = t.local;
  m->odom_seq = t.odom_seq;
  return true;
}

void Fusion::apply_features(const msg::FeatureObservations& m, Track& t) {
  t.have_features = true;
  t.feature_seq = m.seq;
  ++counters_.feature_messages_applied;
  const ccml::RobotId me = m.robot_id;
  std::vector<Measurement> batch;
  std::vector<RangeBearing> lm_z;
  std::vector<Mat2> lm_R;
  for (std::size_t i = 0; i < m.n_features; ++i) {
    const msg::Feature& f = m.features[i];
    const RangeBearing z{f.range, normalize_angle(f.bearing)};
    if (f.kind == msg::FeatureKind::kRobot) {
      if (f.marker_id <= 0 || f.marker_id == static_cast<std::int32_t>(me)) continue;
      const auto other = tracks_.find(static_cast<std::uint16_t>(f.marker_id));
      if (!t.localized || other == tracks_.end() || !other->second.localized) continue;
      Measurement meas{me, Measurement::Target::kRobot, static_cast<std::uint32_t>(f.marker_id), z, mat2(f.cov)};
      if (filter_.innovation(meas).nis() > ccml::chi2_quantile(0.999, 2)) {
        ++counters_.observations_rejected;
        continue;
      }
      batch.push_back(meas);
      continue;
    }
    if (z.range > config_.candidate_range) {
      // Beyond the association range: it could never be matched again, so every sighting
      // would add a new landmark. Counted as rejected.
      ++counters_.observations_rejected;
      continue;
    }
    lm_z.push_back(z);
    lm_R.push_back(mat2(f.cov));
  }
  if (!lm_z.empty()) {
    const Pose2 pose = filter_.robot_pose(me);
    std::vector<ccml::FeatureId> candidates;
    for (ccml::FeatureId id : filter_.feature_ids()) {
      if (!t.localized || (filter_.feature(id) - pose.translation()).norm() < config_.candidate_range) candidates.push_back(id);
    }
    const ccml::JcbbResult jr = ccml::jcbb(filter_, me, lm_z, lm_R, candidates, config_.jcbb);
    std::vector<Measurement> reloc;
    std::vector<Vec2> local, global;
    const double gate = ccml::chi2_quantile(config_.new_feature_confidence, 2);
    for (std::size_t k = 0; k < lm_z.size(); ++k) {
      if (jr.pairing[k]) {
        Measurement meas{me, Measurement::Target::kFeature, *jr.pairing[k], lm_z[k], lm_R[k]};
        if (t.localized) {
          batch.push_back(meas);
        } else {
          reloc.push_back(meas);
          local.push_back(point_from_observation({}, lm_z[k]));
          global.push_back(filter_.feature(*jr.pairing[k]));
        }
        continue;
      }
      if (!t.localized) continue;
      bool ambiguous = false;
      for (ccml::FeatureId id : candidates) {
        if (filter_.innovation({me, Measurement::Target::kFeature, id, lm_z[k], lm_R[k]}).nis() <= gate) {
          ambiguous = true;
          break;
        }
      }
      if (ambiguous) {
        ++counters_.observations_rejected;
      } else {
        filter_.add_feature(me, lm_z[k], lm_R[k]);
        ++counters_.observations_new_features;
      }
    }
    if (!t.localized && reloc.size() >= 3) {
      const ccml::CcmlFilter::Seed seed{me, ccml::align_points(local, global)};
      if (filter_.update(reloc, 15, &seed).applied) {
        t.localized = true;
        ++counters_.robots_localized;
        counters_.observations_used += reloc.size();
      }
    }
  }
  if (!batch.empty() && filter_.update(batch, config_.iterations).applied) counters_.observations_used += batch.size();
}

bool Fusion::localized(std::uint16_t robot) const {
  auto it = tracks_.find(robot);
  return it != tracks_.end() && it->second.localized && filter_.has_robot(robot);
}

bool Fusion::correction(std::uint16_t robot, Nanos stamp, msg::PoseCorrection* out) const {
  if (!localized(robot)) return false;
  const Track& t = tracks_.at(robot);
  const Pose2 global = filter_.robot_pose(robot);
  *out = {};
  out->robot_id = robot;
  out->stamp = stamp;
  out->global_pose = global;
  out->local_to_global = compose(global, inverse(t.local));
  out->global_cov = msg::to_cov(filter_.robot_cov(robot));
  return true;
}

std::vector<std::uint16_t> Fusion::robots() const {
  std::vector<std::uint16_t> ids;
  for (const auto& [id, t] : tracks_) {
    if (t.joined) ids.push_back(id);
  }
  return ids;
}

void Fusion::landmarks(std::vector<msg::Landmark>* out) const {
  out->clear();
  for (ccml::FeatureId id : filter_.feature_ids()) {
    const Vec2 p = filter_.feature(id);
    out->push_back({id, p.x(), p.y(), msg::to_cov(filter_.feature_cov(id))});
  }
}

// ---------------------------------------------------------------- snapshot

namespace {
template <typename T>
void put(std::ostream& o, const T& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  o.write(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
void get(std::istream& i, T* v) {
  if (!i.read(reinterpret_cast<char*>(v), sizeof *v)) throw std::runtime_error("fusion snapshot: truncated");
}
constexpr std::uint32_t kFusionMagic = 0x4E534646;  // "FFSN"
}  // namespace

void Fusion::save(std::ostream& out) const {
  put(out, kFusionMagic);
  put(out, static_cast<std::uint32_t>(sizeof(msg::FeatureObservations)));
  filter_.save(out);
  put(out, counters_);
  put(out, static_cast<std::uint64_t>(tracks_.size()));
  for (const auto& [id, t] : tracks_) {
    put(out, id);
    put(out, t.joined);
    put(out, t.have_odometry);
    put(out, t.odom_seq);
    put(out, t.local);
    put(out, t.have_features);
    put(out, t.feature_seq);
    put(out, t.localized);
    put(out, static_cast<std::uint64_t>(t.pending.size()));
    for (const auto& m : t.pending) put(out, m);
    put(out, static_cast<std::uint64_t>(t.cumulative.size()));
    for (const auto& [seq, cov] : t.cumulative) {
      put(out, seq);
      out.write(reinterpret_cast<const char*>(cov.data()), sizeof(double) * 9);
    }
  }
}

void Fusion::load(std::istream& in) {
  std::uint32_t magic = 0, size = 0;
  get(in, &magic);
  get(in, &size);
  if (magic != kFusionMagic) throw std::runtime_error("fusion snapshot: not a fusion snapshot");
  if (size != sizeof(msg::FeatureObservations)) throw std::runtime_error("fusion snapshot: written by another version");
  filter_ = ccml::CcmlFilter::load(in);
  get(in, &counters_);
  std::uint64_t n = 0;
  get(in, &n);
  tracks_.clear();
  for (std::uint64_t k = 0; k < n; ++k) {
    std::uint16_t id = 0;
    get(in, &id);
    Track& t = tracks_[id];
    get(in, &t.joined);
    get(in, &t.have_odometry);
    get(in, &t.odom_seq);
    get(in, &t.local);
    get(in, &t.have_features);
    get(in, &t.feature_seq);
    get(in, &t.localized);
    std::uint64_t p = 0;
    get(in, &p);
    if (p > 100000) throw std::runtime_error("fusion snapshot: implausible pending count");
    for (std::uint64_t j = 0; j < p; ++j) {
      msg::FeatureObservations m;
      get(in, &m);
      t.pending.push_back(m);
    }
    std::uint64_t nc = 0;
    get(in, &nc);
    if (nc > 10'000'000) throw std::runtime_error("fusion snapshot: implausible odometry window");
    for (std::uint64_t j = 0; j < nc; ++j) {
      std::uint32_t seq = 0;
      get(in, &seq);
      Mat3 cov;
      if (!in.read(reinterpret_cast<char*>(cov.data()), sizeof(double) * 9)) throw std::runtime_error("fusion snapshot: truncated");
      t.cumulative.emplace_back(seq, cov);
    }
  }
}

}  // namespace cairn::base
