#include "basestation/fusion.hpp"

#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>


namespace cairn::base {

using ccml::Measurement;

Fusion::Fusion(FusionConfig config) : config_(std::move(config)) {
  filter_.set_covariance_update(config_.covariance_update);
}

namespace {
Mat2 mat2(const msg::Cov2& a) { return msg::to_mat(a); }
constexpr std::size_t kRetiredEpochs = 8;
}  // namespace

Fusion::Track* Fusion::admit(std::uint16_t robot, Reject* why) {
  auto it = tracks_.find(robot);
  if (it != tracks_.end()) return &it->second;
  if (robot == 0) {  // 0 is the base's own id
    *why = Reject::kUnknownRobot;
    return nullptr;
  }
  if (!config_.robots.count(robot)) {
    if (!config_.allow_unknown_robots) {
      *why = Reject::kUnknownRobot;
      return nullptr;
    }
    std::size_t unknown = 0;
    for (const auto& [id, t] : tracks_) unknown += config_.robots.count(id) == 0;
    if (unknown >= config_.max_unknown_robots) {
      *why = Reject::kRobotCap;
      return nullptr;
    }
  }
  return &tracks_[robot];
}

Fusion::Epoch Fusion::epoch(std::uint16_t robot, Track& t, std::uint32_t e) {
  if (!t.have_epoch) {
    t.have_epoch = true;
    t.epoch = e;
    return Epoch::kCurrent;
  }
  if (e == t.epoch) return Epoch::kCurrent;
  for (std::uint32_t old : t.retired) {
    if (old == e) return Epoch::kStale;
  }
  // A restart: the robot's seq and local frame begin again. Its global pose is where it
  // was, less certain (it may have moved while down): inflate, and re-anchor the local
  // frame on the new epoch's first increment.
  t.retired.push_back(t.epoch);
  if (t.retired.size() > kRetiredEpochs) t.retired.pop_front();
  t.epoch = e;
  t.have_odometry = false;
  t.odom_seq = 0;
  t.have_features = false;
  t.feature_seq = 0;
  counters_.feature_stale += t.pending.size();
  t.pending.clear();
  t.cumulative.clear();
  if (t.joined) {
    const Mat3 q = config_.restart_sigma.cwiseAbs2().asDiagonal();
    if (!filter_.add_process_noise(robot, q)) counters_.rejected.count(Reject::kFilterRefused);
    // Beyond the relocation threshold the robot re-joins by relocation against the map.
    if (std::max(config_.restart_sigma.x(), config_.restart_sigma.y()) > config_.jcbb.relocation_sigma) t.localized = false;
  }
  ++counters_.robots_restarted;
  return Epoch::kRestarted;
}

Fusion::Track& Fusion::join(std::uint16_t robot, Track& t, const Pose2& local_now) {
  if (t.joined) return t;
  auto p = config_.robots.find(robot);
  RobotPrior prior = p != config_.robots.end() ? p->second : config_.unknown;
  // The map frame is the configured priors': a robot not listed never defines it.
  if (p == config_.robots.end()) prior.known = false;
  const Mat3 cov = prior.sigma.cwiseAbs2().asDiagonal();
  filter_.add_robot(robot, compose(prior.pose, local_now), cov);
  t.joined = true;
  t.localized = prior.known;
  ++counters_.robots_joined;
  if (prior.known) ++counters_.robots_localized;
  return t;
}

Fusion::Result Fusion::on_odometry(const msg::OdometryIncrement& m) {
  Reject why{};
  if (auto bad = check(m)) {
    counters_.rejected.count(*bad);
    return Result::kRejected;
  }
  Track* tp = admit(m.robot_id, &why);
  if (!tp) {
    counters_.rejected.count(why);
    return Result::kRejected;
  }
  if (epoch(m.robot_id, *tp, m.boot_epoch) == Epoch::kStale) {
    counters_.rejected.count(Reject::kStaleEpoch);
    return Result::kRejected;
  }
  const Pose2 local = m.local_pose;
  Track& t = join(m.robot_id, *tp, local);
  if (!t.have_odometry) {
    // First increment (of this boot): the robot's local frame is anchored here; its global
    // pose is the filter's (the prior ⊕ this local pose when it just joined).
    t.have_odometry = true;
    t.odom_seq = m.seq;
    t.local = local;
    t.local_t = m.t1;
    t.boot_t0 = m.t1;
    remember(t, Mat3::Zero());
    ++counters_.odometry_applied;
    drain_pending(m.robot_id, t);
    return Result::kApplied;
  }
  if (m.seq <= t.odom_seq) {
    ++counters_.odometry_duplicates;
    return Result::kDuplicate;
  }
  if (m.seq - t.odom_seq > config_.limits.max_seq_gap) {  // one bad seq must not silence the robot
    counters_.rejected.count(Reject::kSeqJump);
    return Result::kRejected;
  }
  Pose2 delta = m.delta;
  Mat3 cov = msg::to_mat(m.delta_cov);
  if (m.seq != t.odom_seq + 1) {
    // Missed increments: bridge with the robot's own local poses, uncertainty scaled by the gap.
    delta = between(t.local, local);
    if (std::hypot(delta.x, delta.y) > config_.limits.max_step_m * static_cast<double>(m.seq - t.odom_seq)) {
      counters_.rejected.count(Reject::kOutOfBounds);
      return Result::kRejected;
    }
    ++counters_.odometry_gaps;
    cov *= static_cast<double>(m.seq - t.odom_seq);
  }
  if (!filter_.predict(m.robot_id, delta, cov)) {
    counters_.rejected.count(Reject::kFilterRefused);
    return Result::kRejected;
  }
  t.odom_seq = m.seq;
  t.local = local;
  t.local_t = m.t1;
  remember(t, cov);
  ++counters_.odometry_applied;
  drain_pending(m.robot_id, t);
  return Result::kApplied;
}

Fusion::Result Fusion::on_features(const msg::FeatureObservations& m) {
  Reject why{};
  if (auto bad = check(m)) {
    counters_.rejected.count(*bad);
    return Result::kRejected;
  }
  Track* tp = admit(m.robot_id, &why);
  if (!tp) {
    counters_.rejected.count(why);
    return Result::kRejected;
  }
  Track& t = *tp;
  if (epoch(m.robot_id, t, m.boot_epoch) == Epoch::kStale) {
    counters_.rejected.count(Reject::kStaleEpoch);
    return Result::kRejected;
  }
  if (t.have_features && m.seq <= t.feature_seq) {
    ++counters_.feature_duplicates;
    return Result::kDuplicate;
  }
  if ((t.have_features && m.seq - t.feature_seq > config_.limits.max_seq_gap) ||
      (t.have_odometry && m.odom_seq > t.odom_seq && m.odom_seq - t.odom_seq > config_.limits.max_seq_gap)) {
    counters_.rejected.count(Reject::kSeqJump);
    return Result::kRejected;
  }
  if (!t.have_odometry || m.odom_seq > t.odom_seq) {
    // Waits in this robot's own bounded queue until its odometry catches up.
    for (const auto& p : t.pending) {
      if (p.seq == m.seq) {
        ++counters_.feature_duplicates;
        return Result::kDuplicate;
      }
    }
    if (t.pending.size() >= config_.max_pending) {
      t.pending.pop_front();
      ++counters_.pending_overflow;
    }
    t.pending.push_back(m);
    return Result::kBuffered;
  }
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

void Fusion::pair_unread_robots(ccml::RobotId me, const std::vector<UnreadSighting>& u, std::vector<Measurement>* batch) {
  if (u.empty()) return;
  std::vector<RangeBearing> z;
  std::vector<Mat2> R;
  for (const UnreadSighting& s : u) {
    z.push_back(s.z);
    R.push_back(s.R);
  }
  std::vector<ccml::RobotId> candidates;
  for (const auto& [id, track] : tracks_) {
    if (id != me && track.localized && filter_.has_robot(id)) candidates.push_back(id);
  }
  // JCBB among the robots: the sightings are paired jointly, and one the equally good
  // hypotheses disagree on is left out.
  const ccml::JcbbResult jr = ccml::jcbb_robots(filter_, me, z, R, candidates, config_.jcbb);
  for (std::size_t k = 0; k < u.size(); ++k) {
    if (jr.budget_exhausted || !jr.pairing[k]) {
      ++counters_.robot_sightings_unpaired;
      continue;
    }
    ++counters_.robot_sightings_paired;
    batch->push_back({me, Measurement::Target::kRobot, *jr.pairing[k], u[k].z, u[k].R});
  }
  if (jr.budget_exhausted) counters_.rejected.count(Reject::kSearchIncomplete);
}

void Fusion::apply_features(const msg::FeatureObservations& m, Track& t) {
  t.have_features = true;
  t.feature_seq = m.seq;
  ++counters_.feature_messages_applied;
  const ccml::RobotId me = m.robot_id;
  const double gate = ccml::chi2_quantile(config_.limits.innovation_confidence, 2);
  std::vector<Measurement> batch;
  std::vector<RangeBearing> lm_z;
  std::vector<Mat2> lm_R;
  std::vector<UnreadSighting> unread;
  for (std::size_t i = 0; i < m.n_features; ++i) {
    const msg::Feature& f = m.features[i];
    const RangeBearing z{f.range, normalize_angle(f.bearing)};
    if (f.kind == msg::FeatureKind::kRobot) {
      ++counters_.robot_sightings;
      if (f.marker_id == -1) {  // a marker not read: paired below by JCBB among the robots
        ++counters_.robot_sightings_unidentified;
        if (config_.robot_observations && t.localized) unread.push_back({z, mat2(f.cov)});
        continue;
      }
      if (!config_.robot_observations) continue;
      // check() bounded it to [1, 65535] and not the observer: the same id for lookup and measurement.
      const auto other_id = static_cast<std::uint16_t>(f.marker_id);
      const auto other = tracks_.find(other_id);
      if (!t.localized || other == tracks_.end() || !other->second.localized || !filter_.has_robot(other_id)) continue;
      batch.push_back({me, Measurement::Target::kRobot, other_id, z, mat2(f.cov)});
      continue;
    }
    if (z.range > config_.candidate_range) {
      // Beyond the association range: it could never be matched again, so every sighting
      // would add a new landmark.
      counters_.rejected.count(Reject::kBeyondRange);
      continue;
    }
    lm_z.push_back(z);
    lm_R.push_back(mat2(f.cov));
  }
  pair_unread_robots(me, unread, &batch);
  if (!lm_z.empty()) {
    const Pose2 pose = filter_.robot_pose(me);
    std::vector<ccml::FeatureId> candidates;
    for (ccml::FeatureId id : filter_.feature_ids()) {
      if (!t.localized || (filter_.feature(id) - pose.translation()).norm() < config_.candidate_range) candidates.push_back(id);
    }
    const ccml::JcbbResult jr = ccml::jcbb(filter_, me, lm_z, lm_R, candidates, config_.jcbb);
    if (jr.budget_exhausted) {
      // The search stopped early: its pairing is not the best one. Use none of this scan's landmarks.
      counters_.rejected.count(Reject::kSearchIncomplete);
    } else if (!t.localized) {
      std::vector<Measurement> reloc;
      std::vector<Vec2> local, global;
      for (std::size_t k = 0; k < lm_z.size(); ++k) {
        if (!jr.pairing[k]) continue;
        reloc.push_back({me, Measurement::Target::kFeature, *jr.pairing[k], lm_z[k], lm_R[k]});
        local.push_back(point_from_observation({}, lm_z[k]));
        global.push_back(filter_.feature(*jr.pairing[k]));
      }
      if (reloc.size() >= 3 && jr.relocation_mode && jr.ambiguous) {
        counters_.rejected.count(Reject::kRelocationAmbiguous);
      } else if (reloc.size() >= 3) {
        const ccml::CcmlFilter::Seed seed{me, ccml::align_points(local, global)};
        const ccml::UpdateResult u = filter_.update(reloc, 15, &seed);
        if (u.applied) {
          t.localized = true;
          ++counters_.robots_localized;
          counters_.observations_used += reloc.size();
        } else if (u.refused) {
          counters_.rejected.count(Reject::kFilterRefused);
        }
      }
    } else {
      const double new_gate = ccml::chi2_quantile(config_.new_feature_confidence, 2);
      for (std::size_t k = 0; k < lm_z.size(); ++k) {
        if (jr.pairing[k]) {
          batch.push_back({me, Measurement::Target::kFeature, *jr.pairing[k], lm_z[k], lm_R[k]});
          auto tent = tentative_.find(*jr.pairing[k]);
          if (tent != tentative_.end() && ++tent->second.seen >= config_.landmark_confirm_count) tentative_.erase(tent);
          continue;
        }
        bool ambiguous = false;
        for (ccml::FeatureId id : candidates) {
          if (filter_.innovation({me, Measurement::Target::kFeature, id, lm_z[k], lm_R[k]}).nis() <= new_gate) {
            ambiguous = true;
            break;
          }
        }
        if (ambiguous) {
          counters_.rejected.count(Reject::kAmbiguousNew);
        } else if (filter_.feature_count() >= config_.max_landmarks) {
          counters_.rejected.count(Reject::kLandmarkCap);
        } else {
          const ccml::FeatureId id = filter_.add_feature(me, lm_z[k], lm_R[k]);
          if (config_.landmark_confirm_count > 1) tentative_[id] = {1, counters_.feature_messages_applied};
          ++counters_.observations_new_features;
        }
      }
    }
  }
  // χ² gate on each observation's innovation before it enters the update.
  std::vector<Measurement> gated;
  std::vector<double> gated_nis;
  for (const Measurement& meas : batch) {
    const ccml::Innovation inn = filter_.innovation(meas);
    const double nis = inn.nis();
    if (!inn.nu.allFinite() || !inn.S.allFinite() || !(nis <= gate)) {
      counters_.rejected.count(Reject::kInnovationGate);
      continue;
    }
    gated.push_back(meas);
    gated_nis.push_back(nis);
  }
  if (!gated.empty()) {
    const ccml::UpdateResult u = filter_.update(gated, config_.iterations);
    if (u.applied) {
      counters_.observations_used += gated.size();
      for (std::size_t k = 0; k < gated.size(); ++k) {
        const bool robot = gated[k].target_kind == Measurement::Target::kRobot;
        counters_.robot_observations_used += robot;
        (robot ? counters_.nis_sum_robot : counters_.nis_sum_landmark) += gated_nis[k];
        ++(robot ? counters_.nis_count_robot : counters_.nis_count_landmark);
      }
    } else if (u.refused) {
      counters_.rejected.count(Reject::kFilterRefused);
    }
  }
  prune_tentative();
}

void Fusion::prune_tentative() {
  for (auto it = tentative_.begin(); it != tentative_.end();) {
    if (counters_.feature_messages_applied - it->second.born <= config_.landmark_confirm_age) {
      ++it;
      continue;
    }
    if (filter_.has_feature(it->first)) filter_.remove_feature(it->first);
    ++counters_.landmarks_pruned;
    it = tentative_.erase(it);
  }
}

bool Fusion::localized(std::uint16_t robot) const {
  auto it = tracks_.find(robot);
  return it != tracks_.end() && it->second.localized && filter_.has_robot(robot);
}

std::optional<Fusion::RobotProgress> Fusion::progress(std::uint16_t robot) const {
  auto it = tracks_.find(robot);
  if (it == tracks_.end()) return std::nullopt;
  return RobotProgress{it->second.epoch, it->second.odom_seq, it->second.feature_seq, localized(robot)};
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

bool Fusion::estimate_clock(std::uint16_t robot, EstimateClock* out) const {
  auto it = tracks_.find(robot);
  if (it == tracks_.end() || !it->second.have_odometry) return false;
  *out = {it->second.local_t, it->second.epoch, it->second.boot_t0};
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
constexpr std::uint32_t kFusionVersion = 2;        // 2: epochs, tentative landmarks, reject counters
}  // namespace

void Fusion::save(std::ostream& out) const {
  put(out, kFusionMagic);
  put(out, kFusionVersion);
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
    put(out, t.have_epoch);
    put(out, t.epoch);
    put(out, static_cast<std::uint64_t>(t.retired.size()));
    for (std::uint32_t e : t.retired) put(out, e);
    put(out, static_cast<std::uint64_t>(t.pending.size()));
    for (const auto& m : t.pending) put(out, m);
    put(out, static_cast<std::uint64_t>(t.cumulative.size()));
    for (const auto& [seq, cov] : t.cumulative) {
      put(out, seq);
      out.write(reinterpret_cast<const char*>(cov.data()), sizeof(double) * 9);
    }
  }
  put(out, static_cast<std::uint64_t>(tentative_.size()));
  for (const auto& [id, tent] : tentative_) {
    put(out, id);
    put(out, tent);
  }
}

void Fusion::load(std::istream& in) {
  std::uint32_t magic = 0, version = 0, size = 0;
  get(in, &magic);
  if (magic != kFusionMagic) throw std::runtime_error("fusion snapshot: not a fusion snapshot");
  get(in, &version);
  if (version != kFusionVersion) throw std::runtime_error("fusion snapshot: written by another version");
  get(in, &size);
  if (size != sizeof(msg::FeatureObservations)) throw std::runtime_error("fusion snapshot: written by another version");
  filter_ = ccml::CcmlFilter::load(in);
  filter_.set_covariance_update(config_.covariance_update);  // configuration, not state
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
    get(in, &t.have_epoch);
    get(in, &t.epoch);
    std::uint64_t nr = 0;
    get(in, &nr);
    if (nr > 64) throw std::runtime_error("fusion snapshot: implausible epoch count");
    for (std::uint64_t j = 0; j < nr; ++j) {
      std::uint32_t e = 0;
      get(in, &e);
      t.retired.push_back(e);
    }
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
  std::uint64_t nt = 0;
  get(in, &nt);
  if (nt > 10'000'000) throw std::runtime_error("fusion snapshot: implausible landmark count");
  tentative_.clear();
  for (std::uint64_t j = 0; j < nt; ++j) {
    ccml::FeatureId id = 0;
    Tentative tent;
    get(in, &id);
    get(in, &tent);
    tentative_[id] = tent;
  }
}

}  // namespace cairn::base
