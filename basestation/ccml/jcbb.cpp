#include "basestation/ccml/jcbb.hpp"

#include <boost/math/distributions/chi_squared.hpp>
#include <algorithm>
#include <cmath>

namespace cairn::ccml {

double chi2_quantile(double confidence, int dof) {
  return boost::math::quantile(boost::math::chi_squared(static_cast<double>(dof)), confidence);
}

Pose2 align_points(std::span<const Vec2> local, std::span<const Vec2> global) {
  const std::size_t n = local.size();
  Vec2 cl = Vec2::Zero(), cg = Vec2::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    cl += local[i];
    cg += global[i];
  }
  cl /= static_cast<double>(n);
  cg /= static_cast<double>(n);
  double sxx = 0, sxy = 0;  // Σ (l × g) and Σ (l · g) of centred points
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = local[i] - cl, b = global[i] - cg;
    sxx += a.x() * b.x() + a.y() * b.y();
    sxy += a.x() * b.y() - a.y() * b.x();
  }
  const double theta = std::atan2(sxy, sxx);
  const Pose2 rot{0, 0, theta};
  const Vec2 t = cg - rot.rotation() * cl;
  return {t.x(), t.y(), theta};
}

namespace {

struct Search {
  Search(const CcmlFilter& f, RobotId o, std::span<const RangeBearing> zs, std::span<const Mat2> Rs,
         std::span<const std::uint32_t> c, Measurement::Target k, const JcbbConfig& config)
      : filter(f), observer(o), z(zs), R(Rs), candidates(c), kind(k), cfg(config) {}
  const CcmlFilter& filter;
  RobotId observer;
  std::span<const RangeBearing> z;
  std::span<const Mat2> R;
  std::span<const std::uint32_t> candidates;  // feature or robot ids, by `kind`
  Measurement::Target kind;
  const JcbbConfig& cfg;
  bool relocation = false;
  // Settled mode (robots): every hypothesis with the most pairings is visited, and an
  // observation the ties do not agree on is contested. `tie` is the first of them.
  bool settled = false;
  std::vector<int> tie;
  std::vector<bool> contested;

  std::vector<std::vector<int>> compatible;  // per observation: candidate indices passing the individual test
  std::vector<int> current;                  // candidate index or -1 per observation
  std::vector<bool> used;
  std::vector<int> best;
  int best_pairings = 0;
  double best_nis = 0.0;
  std::optional<Pose2> best_pose;
  std::size_t nodes = 0;
  bool exhausted = false;

  // Relocation: complete hypotheses (>= 2 pairings) with their aligned poses, best first,
  // to find the best rival whose pose is distinct from the winner's.
  struct Alternative {
    int pairings;
    double nis;
    Pose2 pose;
  };
  std::vector<Alternative> alternatives;
  static constexpr std::size_t kKeep = 64;
  static bool better(const Alternative& a, const Alternative& b) {
    return a.pairings != b.pairings ? a.pairings > b.pairings : a.nis < b.nis;
  }
  void remember(int pairings, double nis, const Pose2& pose) {
    alternatives.push_back({pairings, nis, pose});
    if (alternatives.size() >= 2 * kKeep) trim();
  }
  void trim() {
    std::sort(alternatives.begin(), alternatives.end(), better);
    if (alternatives.size() > kKeep) alternatives.resize(kKeep);
  }

  // Observed points in the observer's frame and their covariance (relocation mode).
  std::vector<Vec2> local;
  std::vector<Mat2> local_cov;

  std::vector<Measurement> hypothesis_measurements(int upto) const {
    std::vector<Measurement> ms;
    for (int i = 0; i <= upto; ++i) {
      if (current[i] < 0) continue;
      Measurement m;
      m.observer = observer;
      m.target_kind = kind;
      m.target = candidates[current[i]];
      m.z = z[i];
      m.R = R[i];
      ms.push_back(m);
    }
    return ms;
  }

  // Linearised joint compatibility (Neira & Tardós): D² = νᵀ S⁻¹ ν ≤ χ²(2k).
  bool joint_compatible(int upto, double* nis) const {
    const auto ms = hypothesis_measurements(upto);
    if (ms.empty()) {
      *nis = 0;
      return true;
    }
    Eigen::VectorXd nu;
    Eigen::MatrixXd S;
    filter.joint_innovation(ms, &nu, &S);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
    *nis = nu.dot(ldlt.solve(nu));
    return *nis <= chi2_quantile(cfg.confidence, static_cast<int>(2 * ms.size()));
  }

  // Location-independent compatibility: the newest pairing must keep every distance to the
  // earlier pairings, and the rigid alignment of all pairings must leave consistent residuals.
  bool relocation_compatible(int upto, double* nis, std::optional<Pose2>* pose) const {
    const int a = upto;
    const Vec2 fa = filter.feature(candidates[current[a]]);
    const Mat2 ca = filter.feature_cov(candidates[current[a]]);
    const double gate1 = chi2_quantile(cfg.confidence, 1);
    std::vector<Vec2> loc, glob;
    std::vector<Mat2> cov;
    for (int b = 0; b <= upto; ++b) {
      if (current[b] < 0) continue;
      const Vec2 fb = filter.feature(candidates[current[b]]);
      if (b != a) {
        const Vec2 dl = local[a] - local[b], dg = fa - fb;
        const double dlen = dl.norm(), glen = dg.norm();
        if (dlen < 1e-6 || glen < 1e-6) return false;
        const Vec2 ul = dl / dlen, ug = dg / glen;
        const double var = ul.dot((local_cov[a] + local_cov[b]) * ul) +
                           ug.dot((ca + filter.feature_cov(candidates[current[b]])) * ug);
        const double diff = dlen - glen;
        if (diff * diff / var > gate1) return false;
      }
      loc.push_back(local[b]);
      glob.push_back(fb);
      cov.push_back(local_cov[b] + filter.feature_cov(candidates[current[b]]));
    }
    *nis = 0;
    if (loc.size() >= 2) {
      const Pose2 T = align_points(loc, glob);
      for (std::size_t i = 0; i < loc.size(); ++i) {
        const Vec2 r = transform_point(T, loc[i]) - glob[i];
        const Mat2 c = T.rotation() * cov[i] * T.rotation().transpose();
        *nis += r.dot(c.ldlt().solve(r));
      }
      // 2k residual components, 3 spent on the alignment.
      const int dof = std::max(1, static_cast<int>(2 * loc.size()) - 3);
      if (*nis > chi2_quantile(cfg.confidence, dof)) return false;
      *pose = T;
    }
    return true;
  }

  void recurse(int i, int pairings, double nis, const std::optional<Pose2>& pose) {
    if (++nodes > cfg.max_nodes) {
      exhausted = true;
      return;
    }
    const int m = static_cast<int>(z.size());
    if (i == m) {
      if (relocation && pairings >= 2 && pose) remember(pairings, nis, *pose);
      if (settled && pairings > 0 && pairings >= best_pairings) {
        if (pairings > best_pairings) {
          tie = current;
          contested.assign(current.size(), false);
        }
        for (std::size_t k = 0; k < current.size(); ++k) contested[k] = contested[k] || current[k] != tie[k];
      }
      if (pairings > best_pairings || (pairings == best_pairings && pairings > 0 && nis < best_nis)) {
        // In relocation mode one pairing says nothing about the pose: require two.
        if (relocation && pairings < 2) return;
        best = current;
        best_pairings = pairings;
        best_nis = nis;
        best_pose = pose;
      }
      return;
    }
    for (int c : compatible[i]) {
      if (used[c]) continue;
      current[i] = c;
      used[c] = true;
      double h_nis = 0;
      std::optional<Pose2> h_pose = pose;
      const bool ok = relocation ? relocation_compatible(i, &h_nis, &h_pose) : joint_compatible(i, &h_nis);
      if (ok) recurse(i + 1, pairings + 1, h_nis, h_pose);
      used[c] = false;
      current[i] = -1;
      if (exhausted) return;
    }
    // Leave observation i unpaired, if that can still beat the best (relocation: or be a
    // rival within the margin, which the ambiguity test needs to see).
    const int reach = pairings + (m - i - 1);
    if (relocation) {
      if (reach >= best_pairings - cfg.relocation_margin) recurse(i + 1, pairings, nis, pose);
    } else if (settled) {
      if (reach >= best_pairings) recurse(i + 1, pairings, nis, pose);  // ties too: they may disagree
    } else if (reach >= best_pairings && !(reach == best_pairings && best_pairings > 0 && nis >= best_nis)) {
      recurse(i + 1, pairings, nis, pose);
    }
  }
};

JcbbResult run(Search& s) {
  const CcmlFilter& filter = s.filter;
  const RobotId observer = s.observer;
  const auto z = s.z;
  const auto R = s.R;
  const auto candidates = s.candidates;
  const JcbbConfig& cfg = s.cfg;
  const std::size_t m = z.size();
  s.compatible.resize(m);
  s.current.assign(m, -1);
  s.used.assign(candidates.size(), false);
  const double gate2 = chi2_quantile(cfg.confidence, 2);
  for (std::size_t i = 0; i < m; ++i) {
    if (s.relocation) {
      const Pose2 origin{};
      Mat23 gp;
      Mat2 gz;
      point_from_observation_jacobians(origin, z[i], &gp, &gz);
      s.local.push_back(point_from_observation(origin, z[i]));
      s.local_cov.push_back(gz * R[i] * gz.transpose());
    }
    for (std::size_t j = 0; j < candidates.size(); ++j) {
      if (s.relocation) {
        s.compatible[i].push_back(static_cast<int>(j));  // no individual gate without a pose
        continue;
      }
      Measurement meas;
      meas.observer = observer;
      meas.target_kind = s.kind;
      meas.target = candidates[j];
      meas.z = z[i];
      meas.R = R[i];
      if (filter.innovation(meas).nis() <= gate2) s.compatible[i].push_back(static_cast<int>(j));
    }
  }
  s.recurse(0, 0, 0.0, std::nullopt);

  JcbbResult r;
  r.pairing.resize(m);
  if (!s.best.empty()) {
    for (std::size_t i = 0; i < m; ++i) {
      if (s.best[i] >= 0) r.pairing[i] = candidates[s.best[i]];
    }
  }
  if (s.settled) {
    for (std::size_t i = 0; i < m && !s.contested.empty(); ++i) {
      if (!s.contested[i]) continue;
      r.pairing[i].reset();
      r.ambiguous = true;
    }
  }
  r.pairings = s.best_pairings;
  r.joint_nis = s.best_nis;
  r.nodes = s.nodes;
  r.budget_exhausted = s.exhausted;
  r.relocation_mode = s.relocation;
  r.aligned_pose = s.best_pose;
  if (s.relocation && s.best_pose) {
    s.trim();
    const Pose2 b = *s.best_pose;
    for (const auto& a : s.alternatives) {
      const bool distinct = std::hypot(a.pose.x - b.x, a.pose.y - b.y) > cfg.relocation_distinct_m ||
                            std::abs(normalize_angle(a.pose.theta - b.theta)) > cfg.relocation_distinct_rad;
      if (!distinct) continue;
      r.rival_pairings = a.pairings;
      break;
    }
    r.ambiguous = r.rival_pairings > 0 && r.rival_pairings + cfg.relocation_margin > r.pairings;
  }
  return r;
}

}  // namespace

JcbbResult jcbb(const CcmlFilter& filter, RobotId observer, std::span<const RangeBearing> z, std::span<const Mat2> R,
                std::span<const FeatureId> candidates, const JcbbConfig& cfg) {
  Search s(filter, observer, z, R, candidates, Measurement::Target::kFeature, cfg);
  const Mat3 pc = filter.robot_cov(observer);
  s.relocation = std::sqrt(std::max(pc(0, 0), pc(1, 1))) > cfg.relocation_sigma;
  return run(s);
}

JcbbResult jcbb_robots(const CcmlFilter& filter, RobotId observer, std::span<const RangeBearing> z,
                       std::span<const Mat2> R, std::span<const RobotId> candidates, const JcbbConfig& cfg) {
  Search s(filter, observer, z, R, candidates, Measurement::Target::kRobot, cfg);
  s.settled = true;
  return run(s);
}

}  // namespace cairn::ccml
