#include "basestation/ccml/filter.hpp"

#include <algorithm>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

namespace cairn::ccml {

CcmlFilter::CcmlFilter(std::size_t initial_capacity) {
  x_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(initial_capacity));
  P_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(initial_capacity), static_cast<Eigen::Index>(initial_capacity));
}

void CcmlFilter::reserve(std::size_t dim) {
  if (dim <= static_cast<std::size_t>(x_.size())) return;
  std::size_t cap = std::max<std::size_t>(dim, static_cast<std::size_t>(x_.size()) * 2);
  const auto c = static_cast<Eigen::Index>(cap), n = static_cast<Eigen::Index>(n_);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(c);
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(c, c);
  x.head(n) = x_.head(n);
  P.topLeftCorner(n, n) = P_.topLeftCorner(n, n);
  x_.swap(x);
  P_.swap(P);
}

int CcmlFilter::append(int dim) {
  reserve(n_ + static_cast<std::size_t>(dim));
  const int offset = static_cast<int>(n_);
  const auto cap = x_.size();
  P_.block(offset, 0, dim, cap).setZero();
  P_.block(0, offset, cap, dim).setZero();
  x_.segment(offset, dim).setZero();
  n_ += static_cast<std::size_t>(dim);
  return offset;
}

void CcmlFilter::erase(int offset, int dim) {
  const auto n = static_cast<Eigen::Index>(n_);
  const Eigen::Index tail = n - offset - dim;
  if (tail > 0) {
    x_.segment(offset, tail) = x_.segment(offset + dim, tail).eval();
    P_.block(offset, 0, tail, n) = P_.block(offset + dim, 0, tail, n).eval();
    P_.block(0, offset, n, tail) = P_.block(0, offset + dim, n, tail).eval();
  }
  n_ -= static_cast<std::size_t>(dim);
  for (auto* map : {&robots_, &features_}) {
    for (auto& [id, slot] : *map) {
      if (slot.offset > offset) slot.offset -= dim;
    }
  }
}

// ---------------------------------------------------------------- robots

void CcmlFilter::add_robot(RobotId id, const Pose2& pose, const Mat3& cov) {
  if (has_robot(id)) throw std::invalid_argument("ccml: robot " + std::to_string(id) + " already in the state");
  const int o = append(3);
  x_.segment<3>(o) = pose.vector();
  P_.block<3, 3>(o, o) = cov;
  robots_[id] = {o, 3};
}

void CcmlFilter::remove_robot(RobotId id) {
  const Slot s = robots_.at(id);
  robots_.erase(id);
  erase(s.offset, s.dim);
}

int CcmlFilter::robot_offset(RobotId id) const {
  auto it = robots_.find(id);
  if (it == robots_.end()) throw std::out_of_range("ccml: unknown robot " + std::to_string(id));
  return it->second.offset;
}

int CcmlFilter::feature_offset(FeatureId id) const {
  auto it = features_.find(id);
  if (it == features_.end()) throw std::out_of_range("ccml: unknown feature " + std::to_string(id));
  return it->second.offset;
}

Pose2 CcmlFilter::robot_pose(RobotId id) const { return pose_at(robot_offset(id), x_); }
Mat3 CcmlFilter::robot_cov(RobotId id) const {
  const int o = robot_offset(id);
  return P_.block<3, 3>(o, o);
}
void CcmlFilter::set_robot_pose(RobotId id, const Pose2& pose) {
  x_.segment<3>(robot_offset(id)) = Pose2{pose.x, pose.y, normalize_angle(pose.theta)}.vector();
}

std::vector<RobotId> CcmlFilter::robot_ids() const {
  std::vector<RobotId> ids;
  for (const auto& [id, s] : robots_) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

// ---------------------------------------------------------------- features

FeatureId CcmlFilter::add_feature(RobotId observer, const RangeBearing& z, const Mat2& R) {
  const int o = robot_offset(observer);
  const Pose2 pose = pose_at(o, x_);
  Mat23 g_pose;
  Mat2 g_z;
  point_from_observation_jacobians(pose, z, &g_pose, &g_z);
  const int f = append(2);
  const auto n = static_cast<Eigen::Index>(n_);
  x_.segment<2>(f) = point_from_observation(pose, z);
  // Cross-covariances with everything already in the state: G_pose · P_pose,•.
  const Eigen::MatrixXd cross = g_pose * P_.block(o, 0, 3, f);
  P_.block(f, 0, 2, f) = cross;
  P_.block(0, f, f, 2) = cross.transpose();
  // Symmetrised: the two triangles of A P Aᵀ are rounded apart (exactly equal under GCC
  // by luck, 1.7e-18 apart under clang), and the update keeps P exactly symmetric.
  const Mat2 own = g_pose * P_.block<3, 3>(o, o) * g_pose.transpose() + g_z * R * g_z.transpose();
  P_.block<2, 2>(f, f) = 0.5 * (own + own.transpose());
  (void)n;
  const FeatureId id = next_feature_++;
  features_[id] = {f, 2};
  return id;
}

FeatureId CcmlFilter::add_feature_prior(const Vec2& position, const Mat2& cov) {
  const int f = append(2);
  x_.segment<2>(f) = position;
  P_.block<2, 2>(f, f) = 0.5 * (cov + cov.transpose());
  const FeatureId id = next_feature_++;
  features_[id] = {f, 2};
  return id;
}

void CcmlFilter::remove_feature(FeatureId id) {
  const Slot s{feature_offset(id), 2};
  features_.erase(id);
  erase(s.offset, s.dim);
}

Vec2 CcmlFilter::feature(FeatureId id) const { return x_.segment<2>(feature_offset(id)); }
Mat2 CcmlFilter::feature_cov(FeatureId id) const {
  const int o = feature_offset(id);
  return P_.block<2, 2>(o, o);
}

std::vector<FeatureId> CcmlFilter::feature_ids() const {
  std::vector<FeatureId> ids;
  for (const auto& [id, s] : features_) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

// ---------------------------------------------------------------- prediction

bool CcmlFilter::predict(RobotId id, const Pose2& delta, const Mat3& delta_cov) {
  const int o = robot_offset(id);
  const auto n = static_cast<Eigen::Index>(n_);
  const Pose2 pose = pose_at(o, x_);
  Mat3 F, G;
  compose_jacobians(pose, delta, &F, &G);
  const Vec3 x_new = compose(pose, delta).vector();
  // P ← F_full P F_fullᵀ where F_full is the identity except the robot's block: O(n).
  // Computed aside first: a prediction that would make the state non-finite is refused.
  const Eigen::MatrixXd rows = F * P_.block(o, 0, 3, n);
  Mat3 corner = rows.middleCols<3>(o) * F.transpose() + G * delta_cov * G.transpose();
  if (!x_new.allFinite() || !rows.allFinite() || !corner.allFinite()) return false;
  x_.segment<3>(o) = x_new;
  P_.block(o, 0, 3, n) = rows;
  P_.block(0, o, n, 3) = rows.transpose();
  P_.block<3, 3>(o, o) = 0.5 * (corner + corner.transpose());
  return true;
}

bool CcmlFilter::add_process_noise(RobotId id, const Mat3& q_global) {
  const int o = robot_offset(id);
  const Mat3 c = P_.block<3, 3>(o, o) + q_global;
  if (!c.allFinite()) return false;
  P_.block<3, 3>(o, o) = c;
  return true;
}

// ---------------------------------------------------------------- measurements

int CcmlFilter::target_offset(const Measurement& m) const {
  return m.target_kind == Measurement::Target::kFeature ? feature_offset(m.target) : robot_offset(m.target);
}

Vec2 CcmlFilter::predicted_measurement(const Measurement& m, const Eigen::VectorXd& x, Block* block) const {
  const int o = robot_offset(m.observer);
  const int t = target_offset(m);
  const Pose2 pose = pose_at(o, x);
  const Vec2 target = x.segment<2>(t);
  block->obs_offset = o;
  block->tgt_offset = t;
  observe_point_jacobians(pose, target, &block->h_obs, &block->h_tgt);
  return observe_point(pose, target).vector();
}

Innovation CcmlFilter::innovation(const Measurement& m) const {
  Eigen::VectorXd nu;
  Eigen::MatrixXd S;
  joint_innovation(std::span<const Measurement>(&m, 1), &nu, &S);
  Innovation inn;
  inn.nu = nu;
  inn.S = S;
  return inn;
}

void CcmlFilter::joint_innovation(std::span<const Measurement> ms, Eigen::VectorXd* nu, Eigen::MatrixXd* S) const {
  const auto m = static_cast<Eigen::Index>(ms.size());
  nu->resize(2 * m);
  S->resize(2 * m, 2 * m);
  std::vector<Block> blocks(ms.size());
  for (Eigen::Index k = 0; k < m; ++k) {
    const Vec2 h = predicted_measurement(ms[k], x_, &blocks[k]);
    (*nu)(2 * k) = ms[k].z.range - h(0);
    (*nu)(2 * k + 1) = normalize_angle(ms[k].z.bearing - h(1));
  }
  // S_kl = H_k P H_lᵀ from the four P blocks that H_k and H_l touch: independent of n.
  for (Eigen::Index k = 0; k < m; ++k) {
    for (Eigen::Index l = k; l < m; ++l) {
      const Block& a = blocks[k];
      const Block& b = blocks[l];
      Mat2 s = a.h_obs * P_.block<3, 3>(a.obs_offset, b.obs_offset) * b.h_obs.transpose() +
               a.h_obs * P_.block<3, 2>(a.obs_offset, b.tgt_offset) * b.h_tgt.transpose() +
               a.h_tgt * P_.block<2, 3>(a.tgt_offset, b.obs_offset) * b.h_obs.transpose() +
               a.h_tgt * P_.block<2, 2>(a.tgt_offset, b.tgt_offset) * b.h_tgt.transpose();
      if (k == l) s += ms[k].R;
      S->block<2, 2>(2 * k, 2 * l) = s;
      if (k != l) S->block<2, 2>(2 * l, 2 * k) = s.transpose();
    }
  }
}

namespace {
// Copies the strict lower triangle onto the upper one. P's columns are a whole capacity
// apart (8 KB at 1024), so reading a row element by element misses the cache and the TLB
// on every element: copying row by row took longer than the rank update itself (n = 654).
// Going tile by tile (8 × 8) keeps the 16 columns it touches in cache: 3× faster there
// (670 → 224 µs).
void mirror_lower_to_upper(Eigen::Ref<Eigen::MatrixXd> P) {
  constexpr Eigen::Index kTile = 8;
  const Eigen::Index n = P.rows();
  for (Eigen::Index j0 = 0; j0 < n; j0 += kTile) {
    const Eigen::Index w = std::min(kTile, n - j0);
    for (Eigen::Index i0 = 0; i0 < j0; i0 += kTile) {  // upper tile (i0, j0) ← lower tile (j0, i0)ᵀ
      for (Eigen::Index c = 0; c < w; ++c) {
        for (Eigen::Index r = 0; r < kTile; ++r) P(i0 + r, j0 + c) = P(j0 + c, i0 + r);
      }
    }
    for (Eigen::Index c = 1; c < w; ++c) {  // the diagonal tile
      for (Eigen::Index r = 0; r < c; ++r) P(j0 + r, j0 + c) = P(j0 + c, j0 + r);
    }
  }
}
}  // namespace

UpdateResult CcmlFilter::update(std::span<const Measurement> ms, int iterations, const Seed* seed) {
  UpdateResult result;
  if (ms.empty()) return result;
  const auto n = static_cast<Eigen::Index>(n_);
  const auto m2 = static_cast<Eigen::Index>(2 * ms.size());
  const Eigen::VectorXd x_prior = x_.head(n);
  Eigen::VectorXd x_iter = x_prior;  // linearisation point
  if (seed) x_iter.segment<3>(robot_offset(seed->robot)) = seed->pose.vector();
  Eigen::MatrixXd PHt(n, m2), S(m2, m2), K;
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd nu(m2);
  std::vector<Block> blocks(ms.size());
  auto Pn = P_.topLeftCorner(n, n);
  iterations = std::max(1, iterations);
  for (int it = 0; it < iterations; ++it) {
    // Innovation at the linearisation point, corrected for its distance from the prior
    // (iterated EKF): ν = z − h(x_i) − H (x̂ − x_i).
    Eigen::VectorXd xi(x_.size());
    xi.head(n) = x_iter;
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const Vec2 h = predicted_measurement(ms[k], xi, &blocks[k]);
      const Block& b = blocks[k];
      Vec3 d_obs = x_prior.segment<3>(b.obs_offset) - x_iter.segment<3>(b.obs_offset);
      d_obs(2) = normalize_angle(d_obs(2));  // iterates may sit on either side of ±π
      const Vec2 dx_term = b.h_obs * d_obs + b.h_tgt * (x_prior.segment<2>(b.tgt_offset) - x_iter.segment<2>(b.tgt_offset));
      const auto r = static_cast<Eigen::Index>(2 * k);
      nu(r) = ms[k].z.range - h(0) - dx_term(0);
      nu(r + 1) = normalize_angle(ms[k].z.bearing - h(1)) - dx_term(1);
      // P Hᵀ column block: only the observer's and the target's columns of P.
      PHt.middleCols<2>(r) = Pn.middleCols<3>(b.obs_offset) * b.h_obs.transpose() +
                             Pn.middleCols<2>(b.tgt_offset) * b.h_tgt.transpose();
    }
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const Block& b = blocks[k];
      const auto r = static_cast<Eigen::Index>(2 * k);
      S.middleRows<2>(r) = b.h_obs * PHt.middleRows<3>(b.obs_offset) + b.h_tgt * PHt.middleRows<2>(b.tgt_offset);
      S.block<2, 2>(r, r) += ms[k].R;
    }
    S = 0.5 * (S + S.transpose()).eval();
    // Eigen's LLT does not notice NaN: check finiteness first. Refusals leave the state as it was.
    if (!S.allFinite() || !nu.allFinite() || !PHt.allFinite()) {
      result.refused = true;
      return result;
    }
    llt.compute(S);
    if (llt.info() != Eigen::Success) return result;  // not positive definite: refuse the update
    K = llt.solve(PHt.transpose()).transpose();
    if (!K.allFinite()) {
      result.refused = true;
      return result;
    }
    // NIS is a statement about the prior: take it from the first linearisation.
    if (it == 0) result.nis = nu.dot(llt.solve(nu));
    const Eigen::VectorXd x_next = x_prior + K * nu;
    Eigen::VectorXd diff = x_next - x_iter;
    for (const auto& [id, slot] : robots_) diff(slot.offset + 2) = normalize_angle(diff(slot.offset + 2));
    const double step = diff.norm();
    x_iter = x_next;
    for (const auto& [id, slot] : robots_) x_iter(slot.offset + 2) = normalize_angle(x_iter(slot.offset + 2));
    if (step < 1e-9) break;
  }
  if (!x_iter.allFinite()) {
    result.refused = true;
    return result;
  }
  if (covariance_update_ == CovarianceUpdate::kJoseph) {
    // Joseph form without H: (I−KH)P(I−KH)ᵀ + KRKᵀ = P − K(PHᵀ)ᵀ − (PHᵀ)Kᵀ + K S Kᵀ.
    const Eigen::MatrixXd KPHt = K * PHt.transpose();
    Eigen::MatrixXd P_next = Pn - KPHt - KPHt.transpose();
    P_next.noalias() += K * S * K.transpose();
    if (!P_next.allFinite()) {
      result.refused = true;
      return result;
    }
    Pn = 0.5 * (P_next + P_next.transpose());
  } else {
    // P − K S Kᵀ = P − (PHᵀ S⁻¹)(PHᵀ)ᵀ = P − W Wᵀ with W = PHᵀ L⁻ᵀ: one rank-2m update of
    // the lower triangle (half the flops of one n×n×2m product), then mirrored, so P stays
    // exactly symmetric. S, its LLT and PHᵀ are those of the last linearisation, like K.
    const Eigen::MatrixXd W = llt.matrixL().solve(PHt.transpose()).transpose();
    // Checked before P is touched (the update is in place): finite and small enough that
    // W Wᵀ cannot overflow, so a refusal leaves the state as it was.
    if (!W.allFinite() || W.cwiseAbs().maxCoeff() > 1e150) {
      result.refused = true;
      return result;
    }
    Pn.selfadjointView<Eigen::Lower>().rankUpdate(W, -1.0);
    mirror_lower_to_upper(Pn);
  }
  x_.head(n) = x_iter;
  result.applied = true;
  result.dof = static_cast<int>(m2);
  return result;
}

namespace {
constexpr std::uint32_t kSnapshotMagic = 0x4C4D4343;  // "CCML"
constexpr std::uint32_t kSnapshotVersion = 1;
template <typename T>
void put(std::ostream& o, const T& v) {
  o.write(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
T get(std::istream& i) {
  T v{};
  if (!i.read(reinterpret_cast<char*>(&v), sizeof v)) throw std::runtime_error("ccml snapshot: truncated");
  return v;
}
}  // namespace

void CcmlFilter::save(std::ostream& out) const {
  put(out, kSnapshotMagic);
  put(out, kSnapshotVersion);
  put(out, static_cast<std::uint64_t>(n_));
  put(out, next_feature_);
  for (const auto* map : {&robots_, &features_}) {
    put(out, static_cast<std::uint64_t>(map->size()));
    for (const auto& [id, slot] : *map) {
      put(out, id);
      put(out, static_cast<std::int32_t>(slot.offset));
      put(out, static_cast<std::int32_t>(slot.dim));
    }
  }
  const auto n = static_cast<Eigen::Index>(n_);
  out.write(reinterpret_cast<const char*>(x_.data()), static_cast<std::streamsize>(sizeof(double) * n_));
  for (Eigen::Index c = 0; c < n; ++c) {
    out.write(reinterpret_cast<const char*>(P_.col(c).data()), static_cast<std::streamsize>(sizeof(double) * n_));
  }
}

CcmlFilter CcmlFilter::load(std::istream& in) {
  if (get<std::uint32_t>(in) != kSnapshotMagic) throw std::runtime_error("ccml snapshot: not a CCML snapshot");
  if (get<std::uint32_t>(in) != kSnapshotVersion) throw std::runtime_error("ccml snapshot: unsupported version");
  const auto n = get<std::uint64_t>(in);
  if (n > 1'000'000) throw std::runtime_error("ccml snapshot: implausible state size");
  CcmlFilter f(std::max<std::size_t>(n, 8));
  f.n_ = n;
  f.next_feature_ = get<FeatureId>(in);
  for (auto* map : {&f.robots_, &f.features_}) {
    const auto count = get<std::uint64_t>(in);
    for (std::uint64_t k = 0; k < count; ++k) {
      const auto id = get<std::uint32_t>(in);
      const auto off = get<std::int32_t>(in);
      const auto dim = get<std::int32_t>(in);
      if (off < 0 || dim <= 0 || static_cast<std::uint64_t>(off + dim) > n) throw std::runtime_error("ccml snapshot: bad slot");
      (*map)[id] = {off, dim};
    }
  }
  const auto ni = static_cast<Eigen::Index>(n);
  if (!in.read(reinterpret_cast<char*>(f.x_.data()), static_cast<std::streamsize>(sizeof(double) * n))) {
    throw std::runtime_error("ccml snapshot: truncated");
  }
  for (Eigen::Index c = 0; c < ni; ++c) {
    if (!in.read(reinterpret_cast<char*>(f.P_.col(c).data()), static_cast<std::streamsize>(sizeof(double) * n))) {
      throw std::runtime_error("ccml snapshot: truncated");
    }
  }
  return f;
}

double CcmlFilter::min_eigenvalue() const {
  if (n_ == 0) return 0.0;
  const Eigen::MatrixXd P = covariance();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (P + P.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues().minCoeff();
}

double CcmlFilter::max_asymmetry() const {
  if (n_ == 0) return 0.0;
  const Eigen::MatrixXd P = covariance();
  return (P - P.transpose()).cwiseAbs().maxCoeff();
}

}  // namespace cairn::ccml
