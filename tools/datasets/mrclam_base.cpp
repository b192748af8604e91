#include "tools/datasets/mrclam_base.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "basestation/ccml/jcbb.hpp"

namespace cairn::ccml {

namespace {

struct Event {
  double t;
  int robot;
  bool image;  // else an odometry row
  std::size_t index;
};

// One robot as the base hears it, and its score.
struct Stream {
  bool started = false;  // its first increment sent: its local frame is anchored
  double t_last = 0, v = 0, w = 0;
  Pose2 local;
  std::uint32_t odom_seq = 0, feature_seq = 0;
  std::size_t gt_hint = 0;
  double sq = 0, nees = 0;
  std::size_t n = 0;
  double localized_at = -1;
};

}  // namespace

MrclamResult run_mrclam_base(const MrclamData& d, const MrclamOptions& o, base::FusionConfig c) {
  const auto wall0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(d.robots.size());
  const bool gt = d.has_robot_groundtruth();
  const double t0 = mrclam_start(d);
  const double t_end = mrclam_end(d, o);

  // The fleet. A robot whose ground truth starts later (robot 4 of Dataset 6) starts then.
  c.robots.clear();
  c.iterations = o.iterations;
  std::vector<double> start(static_cast<std::size_t>(n), t0);
  const Vec3 sigma0(o.initial_sigma_xy, o.initial_sigma_xy, o.initial_sigma_theta);
  for (int r = 0; r < n; ++r) {
    base::RobotPrior p;  // unknown by default: joins by relocation
    if (gt) {
      const MrclamPose& g = d.robots[static_cast<std::size_t>(r)].groundtruth.front();
      p = {true, Pose2{g.x, g.y, g.theta}, sigma0};
      start[static_cast<std::size_t>(r)] = std::max(t0, g.t);
    } else if (r == 0) {
      p = {true, Pose2{}, sigma0};
    }
    c.robots[static_cast<std::uint16_t>(r + 1)] = p;
  }
  base::Fusion fusion(c);

  std::vector<Event> events;
  for (int r = 0; r < n; ++r) {
    const auto& rd = d.robots[static_cast<std::size_t>(r)];
    for (std::size_t i = 0; i < rd.odometry.size(); ++i) events.push_back({rd.odometry[i].t, r, false, i});
    for (std::size_t i = 0; i < rd.measurements.size(); ++i) {
      if (i > 0 && rd.measurements[i].t == rd.measurements[i - 1].t) continue;  // one message per image
      events.push_back({rd.measurements[i].t, r, true, i});
    }
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });

  std::vector<Stream> s(static_cast<std::size_t>(n));
  const Mat2 R = Vec2(o.range_sigma * o.range_sigma, o.bearing_sigma * o.bearing_sigma).asDiagonal();
  auto nanos = [&](double t) { return static_cast<Nanos>(std::llround((t - t0) * 1e9)); };
  // The robot's motion since its last message, as the OdometryIncrement it sends.
  auto increment = [&](int r, double t) {
    Stream& st = s[static_cast<std::size_t>(r)];
    msg::OdometryIncrement m{};
    m.robot_id = static_cast<std::uint16_t>(r + 1);
    m.boot_epoch = 1;
    if (!st.started) {  // the first: zero motion, anchors the local frame at the start
      st.started = true;
      st.t_last = t;
    } else {
      const double dt = t - st.t_last;
      if (dt <= 0) return;
      m.delta = arc_motion(st.v, st.w, dt);
      m.delta_cov = msg::to_cov(mrclam_odometry_cov(o, st.v, st.w, dt));
      st.local = compose(st.local, m.delta);
      m.t0 = nanos(st.t_last);
      st.t_last = t;
    }
    m.seq = ++st.odom_seq;
    m.t1 = nanos(t);
    if (st.odom_seq == 1) m.t0 = m.t1;
    m.local_pose = st.local;
    fusion.on_odometry(m);
  };
  auto image = [&](int r, double t, std::size_t first, std::size_t last) {
    Stream& st = s[static_cast<std::size_t>(r)];
    msg::FeatureObservations f{};
    f.robot_id = static_cast<std::uint16_t>(r + 1);
    f.boot_epoch = 1;
    f.stamp = nanos(t);
    f.local_pose = st.local;
    f.odom_seq = st.odom_seq;
    const auto& ms = d.robots[static_cast<std::size_t>(r)].measurements;
    for (std::size_t i = first; i < last && f.n_features < msg::kMaxFeatures; ++i) {
      const MrclamMeasurement& m = ms[i];
      if (m.subject == r + 1) continue;
      const bool robot = m.subject >= 1 && m.subject <= n;
      msg::Feature& ft = f.features[f.n_features++];
      ft.kind = robot ? msg::FeatureKind::kRobot : msg::FeatureKind::kLandmark;
      ft.marker_id = robot ? m.subject : -1;  // a robot's marker names it; a landmark's barcode is not passed on
      ft.range = m.range;
      ft.bearing = normalize_angle(m.bearing);
      ft.cov = msg::to_cov(R);
    }
    if (f.n_features == 0) return;
    f.seq = ++st.feature_seq;
    fusion.on_features(f);
  };
  auto sample = [&](int r, double t) {
    Stream& st = s[static_cast<std::size_t>(r)];
    const auto id = static_cast<std::uint16_t>(r + 1);
    if (!fusion.localized(id)) return;
    const auto truth = interpolate_groundtruth(d.robots[static_cast<std::size_t>(r)].groundtruth, t, &st.gt_hint);
    if (!truth || t - t0 < o.score_from) return;
    const Pose2 est = fusion.filter().robot_pose(id);
    const Vec3 e(est.x - truth->x, est.y - truth->y, normalize_angle(est.theta - truth->theta));
    st.sq += e.head<2>().squaredNorm();
    st.nees += e.dot(fusion.filter().robot_cov(id).ldlt().solve(e));
    ++st.n;
  };

  for (const Event& e : events) {
    if (e.t > t_end) break;
    Stream& st = s[static_cast<std::size_t>(e.robot)];
    const auto& rd = d.robots[static_cast<std::size_t>(e.robot)];
    if (e.t < start[static_cast<std::size_t>(e.robot)]) {
      if (!e.image) {  // keep the velocity that holds when the robot starts
        st.v = rd.odometry[e.index].v;
        st.w = rd.odometry[e.index].w;
      }
      continue;
    }
    increment(e.robot, e.t);
    if (st.localized_at < 0 && fusion.localized(static_cast<std::uint16_t>(e.robot + 1))) st.localized_at = e.t - t0;
    if (!e.image) {
      st.v = rd.odometry[e.index].v;
      st.w = rd.odometry[e.index].w;
      sample(e.robot, e.t);
      continue;
    }
    std::size_t last = e.index;
    while (last < rd.measurements.size() && rd.measurements[last].t == e.t) ++last;
    image(e.robot, e.t, e.index, last);
  }

  // ---- results
  MrclamResult res;
  res.mode = "base-fusion";
  res.association = "jcbb";
  res.association_errors_known = false;
  res.unknown_barcodes_dropped = d.unknown_barcodes_dropped;
  res.duration_s = t_end - t0;
  const base::FusionCounters& k = fusion.counters();
  res.measurements_used = k.observations_used;
  res.measurements_rejected = k.rejected.total();
  double sum = 0;
  int with_gt = 0;
  for (int r = 0; r < n; ++r) {
    const Stream& st = s[static_cast<std::size_t>(r)];
    MrclamRobotResult rr;
    rr.robot = r + 1;
    rr.samples = st.n;
    rr.localized = fusion.localized(static_cast<std::uint16_t>(r + 1));
    rr.localized_at = st.localized_at;
    if (st.n > 0) {
      rr.rmse_xy = std::sqrt(st.sq / static_cast<double>(st.n));
      rr.nees_mean = st.nees / static_cast<double>(st.n);
      sum += rr.rmse_xy;
      ++with_gt;
    }
    res.robots.push_back(rr);
  }
  if (with_gt) res.rmse_xy_mean = sum / with_gt;

  // Landmarks, without labels: the label-free fit pairs each feature with its nearest
  // ground-truth landmark; each landmark is matched by the nearest of the features paired
  // with it (the others are duplicates or clutter).
  std::vector<msg::Landmark> lms;
  fusion.landmarks(&lms);
  res.features = lms.size();
  std::vector<Vec2> est, g;
  std::vector<int> labels;
  for (const auto& l : lms) est.emplace_back(l.x, l.y);
  for (const auto& [label, p] : d.landmarks) {
    g.push_back(p);
    labels.push_back(label);
  }
  std::vector<int> nn;
  res.landmark_rmse_label_free = label_free_fit(est, g, &nn);
  if (nn.size() == est.size() && est.size() >= 2) {
    std::vector<Vec2> pe, pg;
    for (std::size_t i = 0; i < est.size(); ++i) {
      pe.push_back(est[i]);
      pg.push_back(g[static_cast<std::size_t>(nn[i])]);
    }
    const Pose2 T = align_points(pe, pg);  // the fit's final transform
    std::vector<int> best(g.size(), -1);
    for (std::size_t i = 0; i < est.size(); ++i) {
      const auto j = static_cast<std::size_t>(nn[i]);
      const double di = (transform_point(T, est[i]) - g[j]).squaredNorm();
      if (best[j] < 0 || di < (transform_point(T, est[static_cast<std::size_t>(best[j])]) - g[j]).squaredNorm()) {
        best[j] = static_cast<int>(i);
      }
    }
    double sq = 0, sq_unaligned = 0;
    for (std::size_t j = 0; j < g.size(); ++j) {
      if (best[j] < 0) continue;
      const Vec2& e = est[static_cast<std::size_t>(best[j])];
      res.map.emplace_back(labels[j], e);
      sq += (transform_point(T, e) - g[j]).squaredNorm();
      sq_unaligned += (e - g[j]).squaredNorm();
    }
    res.landmarks_matched = res.map.size();
    res.alignment = T;
    if (!res.map.empty()) {
      res.landmark_rmse_aligned = std::sqrt(sq / static_cast<double>(res.map.size()));
      res.landmark_rmse_unaligned = std::sqrt(sq_unaligned / static_cast<double>(res.map.size()));
    }
  }
  res.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return res;
}

}  // namespace cairn::ccml
