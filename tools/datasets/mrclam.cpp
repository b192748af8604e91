#include "tools/datasets/mrclam.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "basestation/ccml/jcbb.hpp"
#include "common/text_lines.hpp"
#include "tools/datasets/read_text.hpp"

namespace cairn::ccml {

const char* mode_name(MrclamOptions::Mode m) {
  switch (m) {
    case MrclamOptions::Mode::kDeadReckoning: return "dead-reckoning";
    case MrclamOptions::Mode::kSingleRobot: return "single-robot-slam";
    case MrclamOptions::Mode::kCooperative: return "cooperative-cml";
  }
  return "?";
}
const char* association_name(MrclamOptions::Association a) {
  return a == MrclamOptions::Association::kLabels ? "labels" : "jcbb";
}

bool MrclamData::has_robot_groundtruth() const {
  return std::all_of(robots.begin(), robots.end(), [](const MrclamRobotData& r) { return !r.groundtruth.empty(); });
}

namespace {

// Rows of whitespace-separated numbers; '#' lines and CR are ignored.
// `path` may be stored gzipped as `path.gz` (data/mrclam/ is).
std::vector<std::vector<double>> read_table(const std::string& wanted, std::size_t columns, bool required) {
  const std::string path = datasets::plain_or_gz(wanted);
  const std::optional<std::string> text = datasets::read_text_file(path);
  if (!text) {
    if (required) throw std::runtime_error(path + ": cannot open");
    return {};
  }
  std::vector<std::vector<double>> rows;
  for_each_line(*text, [&](std::size_t lineno, const std::string& whole) {
    std::string_view line = whole;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos || line[first] == '#') return;
    std::istringstream s{std::string(line)};
    std::vector<double> row(columns);
    for (std::size_t c = 0; c < columns; ++c) {
      if (!(s >> row[c]) || !std::isfinite(row[c])) {
        throw std::runtime_error(path + ":" + std::to_string(lineno) + ": expected " + std::to_string(columns) +
                                 " numbers, got '" + std::string(line) + "'");
      }
    }
    rows.push_back(std::move(row));
  });
  return rows;
}

}  // namespace

MrclamData load_mrclam(const std::string& dir) {
  MrclamData d;
  d.dir = dir;
  std::map<int, int> subject_of_barcode;
  for (const auto& r : read_table(dir + "/Barcodes.dat", 2, true)) subject_of_barcode[static_cast<int>(r[1])] = static_cast<int>(r[0]);
  for (const auto& r : read_table(dir + "/Landmark_Groundtruth.dat", 5, true)) d.landmarks[static_cast<int>(r[0])] = {r[1], r[2]};
  for (int robot = 1; robot <= 5; ++robot) {
    const std::string p = dir + "/Robot" + std::to_string(robot) + "_";
    MrclamRobotData rd;
    for (const auto& r : read_table(p + "Odometry.dat", 3, true)) rd.odometry.push_back({r[0], r[1], r[2]});
    for (const auto& r : read_table(p + "Measurement.dat", 4, true)) {
      auto it = subject_of_barcode.find(static_cast<int>(r[1]));
      if (it == subject_of_barcode.end()) {
        ++d.unknown_barcodes_dropped;
        continue;
      }
      rd.measurements.push_back({r[0], it->second, r[2], r[3]});
    }
    for (const auto& r : read_table(p + "Groundtruth.dat", 4, false)) rd.groundtruth.push_back({r[0], r[1], r[2], r[3]});
    auto by_time = [](const auto& a, const auto& b) { return a.t < b.t; };
    std::stable_sort(rd.odometry.begin(), rd.odometry.end(), by_time);
    std::stable_sort(rd.measurements.begin(), rd.measurements.end(), by_time);
    std::stable_sort(rd.groundtruth.begin(), rd.groundtruth.end(), by_time);
    d.robots.push_back(std::move(rd));
  }
  return d;
}

namespace {

struct Event {
  double t;
  int robot;
  int kind;  // 0 odometry, 1 measurement
  std::size_t index;
};

}  // namespace

std::optional<Pose2> interpolate_groundtruth(const std::vector<MrclamPose>& gt, double t, std::size_t* hint) {
  if (gt.empty() || t < gt.front().t || t > gt.back().t) return std::nullopt;
  std::size_t i = *hint;
  while (i + 1 < gt.size() && gt[i + 1].t < t) ++i;
  *hint = i;
  const MrclamPose& a = gt[i];
  const MrclamPose& b = gt[std::min(i + 1, gt.size() - 1)];
  const double u = b.t > a.t ? (t - a.t) / (b.t - a.t) : 0.0;
  return Pose2{a.x + u * (b.x - a.x), a.y + u * (b.y - a.y), normalize_angle(a.theta + u * normalize_angle(b.theta - a.theta))};
}

Mat3 mrclam_odometry_cov(const MrclamOptions& o, double v, double w, double dt) {
  const double dist = std::abs(v * dt), turn = std::abs(w * dt);
  const double sx = o.odom_v_rel * dist, sy = 0.3 * o.odom_v_rel * dist, st = o.odom_w_rel * turn + 0.1 * o.odom_w_rel * dist;
  return Vec3(sx * sx + o.odom_v_rate * o.odom_v_rate * dt, sy * sy + 0.25 * o.odom_v_rate * o.odom_v_rate * dt,
              st * st + o.odom_w_rate * o.odom_w_rate * dt)
      .asDiagonal();
}

double mrclam_start(const MrclamData& d) {
  const bool gt = d.has_robot_groundtruth();
  double t0 = 1e300;
  for (const auto& rd : d.robots) {
    if (gt) t0 = std::min(t0, rd.groundtruth.front().t);
    else if (!rd.odometry.empty()) t0 = std::min(t0, rd.odometry.front().t);
  }
  return t0;
}

double mrclam_end(const MrclamData& d, const MrclamOptions& o) {
  const bool gt = d.has_robot_groundtruth();
  double t_end = 1e300;
  for (const auto& rd : d.robots) {
    if (gt) t_end = std::min(t_end, rd.groundtruth.back().t);
    else if (!rd.odometry.empty()) t_end = std::min(t_end, rd.odometry.back().t);
  }
  if (o.duration > 0) t_end = std::min(t_end, mrclam_start(d) + o.duration);
  return t_end;
}

double label_free_fit(const std::vector<Vec2>& est, const std::vector<Vec2>& gt, std::vector<int>* nearest) {
  if (est.size() < 2 || gt.empty()) return -1;
  Vec2 ce = Vec2::Zero(), cg = Vec2::Zero();
  for (const auto& p : est) ce += p;
  for (const auto& p : gt) cg += p;
  ce /= static_cast<double>(est.size());
  cg /= static_cast<double>(gt.size());
  double best = 1e300;
  for (int a = 0; a < 72; ++a) {
    Pose2 T{0, 0, a * 5.0 * std::numbers::pi / 180.0};
    const Vec2 t = cg - T.rotation() * ce;
    T.x = t.x();
    T.y = t.y();
    double rmse = 0;
    std::vector<int> nn(est.size());
    for (int it = 0; it < 30; ++it) {
      std::vector<Vec2> L, G;
      rmse = 0;
      for (std::size_t i = 0; i < est.size(); ++i) {
        const Vec2 q = transform_point(T, est[i]);
        double bd = 1e300;
        for (std::size_t j = 0; j < gt.size(); ++j) {
          const double dd = (gt[j] - q).squaredNorm();
          if (dd < bd) {
            bd = dd;
            nn[i] = static_cast<int>(j);
          }
        }
        L.push_back(est[i]);
        G.push_back(gt[nn[i]]);
        rmse += bd;
      }
      rmse = std::sqrt(rmse / static_cast<double>(est.size()));
      T = align_points(L, G);
    }
    if (rmse < best) {
      best = rmse;
      *nearest = nn;
    }
  }
  return best;
}

namespace {

class Runner {
 public:
  Runner(const MrclamData& d, const MrclamOptions& o) : d_(d), o_(o), robots_(d.robots.size()) {
    R_ = Vec2(o.range_sigma * o.range_sigma, o.bearing_sigma * o.bearing_sigma).asDiagonal();
    gate_ = chi2_quantile(o.outlier_confidence, 2);
  }

  MrclamResult run();

 private:
  struct RobotRun {
    double t_last = 0, v = 0, w = 0;
    std::size_t gt_hint = 0;
    bool in_filter = false;        // added to its filter (joined the estimate)
    bool localized = false;
    double localized_at = -1;
    double sq = 0, nees = 0;
    std::size_t n = 0;
  };
  struct FeatureStats {
    std::map<int, int> labels;  // hidden true subject -> count of observations associated
  };

  CcmlFilter& filter(int r) { return filters_[o_.mode == MrclamOptions::Mode::kCooperative ? 0 : r]; }
  void join_at_groundtruth(int r);
  void predict(int r, double t);
  void sample(int r, double t);
  void measure(int r, double t, std::size_t first, std::size_t last);
  FeatureId new_feature(int r, int subject, const RangeBearing& z);
  void relocate(int r, double t, std::vector<Measurement>& ms, const std::vector<Vec2>& local);

  const MrclamData& d_;
  const MrclamOptions& o_;
  std::vector<RobotRun> robots_;
  std::vector<CcmlFilter> filters_;
  std::vector<std::map<int, FeatureId>> label_features_;             // per filter: subject -> feature
  std::vector<std::map<FeatureId, FeatureStats>> feature_stats_;     // per filter
  Mat2 R_;
  Mat3 P0_;
  double gate_ = 0;
  double t0_ = 0;
  MrclamResult res_;
};

// With ground truth, a robot starts from its first ground-truth sample, at that sample's
// time: the common start t0 for most, later for a robot whose ground truth starts later
// (robot 4 of Dataset 6, by 15 ms). Until then it is not in the estimate: its odometry
// only sets the velocity that holds when it joins, its observations and the others'
// observations of it are not used, and there is nothing to score it against.
void Runner::join_at_groundtruth(int r) {
  RobotRun& rr = robots_[r];
  const MrclamPose& g = d_.robots[r].groundtruth.front();
  filter(r).add_robot(static_cast<RobotId>(r + 1), Pose2{g.x, g.y, g.theta}, P0_);
  rr.in_filter = true;
  rr.t_last = std::max(t0_, g.t);
  rr.localized = true;
  rr.localized_at = rr.t_last - t0_;
}

void Runner::predict(int r, double t) {
  RobotRun& rr = robots_[r];
  const double dt = t - rr.t_last;
  if (dt <= 0) return;
  rr.t_last = t;
  filter(r).predict(static_cast<RobotId>(r + 1), arc_motion(rr.v, rr.w, dt), mrclam_odometry_cov(o_, rr.v, rr.w, dt));
}

void Runner::sample(int r, double t) {
  RobotRun& rr = robots_[r];
  const auto gt = interpolate_groundtruth(d_.robots[r].groundtruth, t, &rr.gt_hint);
  if (!gt || !rr.localized || t - t0_ < o_.score_from) return;
  const Pose2 est = filter(r).robot_pose(static_cast<RobotId>(r + 1));
  const Vec3 e(est.x - gt->x, est.y - gt->y, normalize_angle(est.theta - gt->theta));
  rr.sq += e.head<2>().squaredNorm();
  rr.nees += e.dot(filter(r).robot_cov(static_cast<RobotId>(r + 1)).ldlt().solve(e));
  ++rr.n;
}

FeatureId Runner::new_feature(int r, int subject, const RangeBearing& z) {
  const int fi = o_.mode == MrclamOptions::Mode::kCooperative ? 0 : r;
  const FeatureId id = filter(r).add_feature(static_cast<RobotId>(r + 1), z, R_);
  feature_stats_[fi][id].labels[subject]++;
  return id;
}

// A robot whose pose is unknown (no ground truth to start from) joins the map once it
// sees enough mapped landmarks: align its observations to them, then an iterated update
// seeded with the alignment (the paper's B21b case).
void Runner::relocate(int r, double t, std::vector<Measurement>& ms, const std::vector<Vec2>& local) {
  std::vector<Vec2> loc, glob;
  for (std::size_t i = 0; i < ms.size(); ++i) {
    loc.push_back(local[i]);
    glob.push_back(filter(r).feature(ms[i].target));
  }
  const CcmlFilter::Seed seed{static_cast<RobotId>(r + 1), align_points(loc, glob)};
  if (filter(r).update(ms, 15, &seed).applied) {
    robots_[r].localized = true;
    robots_[r].localized_at = t - t0_;
    res_.measurements_used += ms.size();
  }
  ms.clear();
}

void Runner::measure(int r, double t, std::size_t first, std::size_t last) {
  const auto& all = d_.robots[r].measurements;
  const RobotId me = static_cast<RobotId>(r + 1);
  const int fi = o_.mode == MrclamOptions::Mode::kCooperative ? 0 : r;
  CcmlFilter& f = filter(r);
  std::vector<Measurement> batch;
  std::vector<RangeBearing> lm_z;
  std::vector<int> lm_label;
  for (std::size_t i = first; i < last; ++i) {
    const MrclamMeasurement& m = all[i];
    const RangeBearing z{m.range, normalize_angle(m.bearing)};
    if (m.subject >= 1 && m.subject <= 5) {
      const int other = m.subject - 1;
      if (o_.mode != MrclamOptions::Mode::kCooperative || other == r || !robots_[r].localized || !robots_[other].localized) continue;
      Measurement meas{me, Measurement::Target::kRobot, static_cast<RobotId>(m.subject), z, R_};
      if (f.innovation(meas).nis() > gate_) {
        ++res_.measurements_rejected;
        continue;
      }
      batch.push_back(meas);
      continue;
    }
    lm_z.push_back(z);
    lm_label.push_back(m.subject);
  }

  std::vector<Vec2> local;  // observed points in the robot frame (relocation)
  std::vector<Measurement> reloc;
  if (o_.association == MrclamOptions::Association::kLabels) {
    for (std::size_t k = 0; k < lm_z.size(); ++k) {
      auto it = label_features_[fi].find(lm_label[k]);
      if (it == label_features_[fi].end()) {
        if (robots_[r].localized) label_features_[fi][lm_label[k]] = new_feature(r, lm_label[k], lm_z[k]);
        continue;
      }
      Measurement meas{me, Measurement::Target::kFeature, it->second, lm_z[k], R_};
      if (!robots_[r].localized) {
        reloc.push_back(meas);
        local.push_back(point_from_observation({}, lm_z[k]));
        continue;
      }
      if (f.innovation(meas).nis() > gate_) {
        ++res_.measurements_rejected;
        continue;
      }
      feature_stats_[fi][it->second].labels[lm_label[k]]++;
      batch.push_back(meas);
    }
  } else if (!lm_z.empty()) {
    const Pose2 pose = f.robot_pose(me);
    std::vector<FeatureId> candidates;
    for (FeatureId id : f.feature_ids()) {
      if (!robots_[r].localized || (f.feature(id) - pose.translation()).norm() < o_.max_range) candidates.push_back(id);
    }
    const std::vector<Mat2> Rs(lm_z.size(), R_);
    const JcbbResult jr = jcbb(f, me, lm_z, Rs, candidates);
    for (std::size_t k = 0; k < lm_z.size(); ++k) {
      if (jr.pairing[k]) {
        Measurement meas{me, Measurement::Target::kFeature, *jr.pairing[k], lm_z[k], R_};
        feature_stats_[fi][*jr.pairing[k]].labels[lm_label[k]]++;
        if (!robots_[r].localized) {
          reloc.push_back(meas);
          local.push_back(point_from_observation({}, lm_z[k]));
        } else {
          batch.push_back(meas);
        }
        continue;
      }
      if (!robots_[r].localized) continue;
      // Unpaired: a new feature only if it is compatible with no existing one (else ambiguous: dropped).
      bool near_existing = false;
      for (FeatureId id : candidates) {
        if (f.innovation({me, Measurement::Target::kFeature, id, lm_z[k], R_}).nis() <= gate_) {
          near_existing = true;
          break;
        }
      }
      if (near_existing) {
        ++res_.measurements_rejected;
      } else {
        new_feature(r, lm_label[k], lm_z[k]);
      }
    }
  }
  if (!robots_[r].localized && reloc.size() >= 3) relocate(r, t, reloc, local);
  if (!batch.empty() && f.update(batch, o_.iterations).applied) res_.measurements_used += batch.size();
}

MrclamResult Runner::run() {
  const auto wall0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(d_.robots.size());
  const bool gt = d_.has_robot_groundtruth();
  const bool coop = o_.mode == MrclamOptions::Mode::kCooperative;
  filters_.resize(coop ? 1 : n);
  label_features_.resize(filters_.size());
  feature_stats_.resize(filters_.size());

  // Start: the first ground-truth instant (robots stand still until their first odometry), else the first odometry.
  // A robot whose ground truth starts later joins then (join_at_groundtruth).
  t0_ = mrclam_start(d_);
  const double t_end = mrclam_end(d_, o_);

  P0_ = Vec3(o_.initial_sigma_xy * o_.initial_sigma_xy, o_.initial_sigma_xy * o_.initial_sigma_xy,
             o_.initial_sigma_theta * o_.initial_sigma_theta)
            .asDiagonal();
  for (int r = 0; r < n; ++r) {
    robots_[r].t_last = t0_;
    if (gt) {
      if (d_.robots[r].groundtruth.front().t <= t0_) join_at_groundtruth(r);  // else when its ground truth starts
      continue;
    }
    robots_[r].in_filter = true;
    if (r == 0 || !coop) {
      // No ground truth: each map's frame is defined by its first robot's start.
      filter(r).add_robot(static_cast<RobotId>(r + 1), {}, P0_);
      robots_[r].localized = true;
      robots_[r].localized_at = 0;
    } else {
      filter(r).add_robot(static_cast<RobotId>(r + 1), {}, Vec3(1e4, 1e4, 10.0).asDiagonal());
    }
  }

  std::vector<Event> events;
  for (int r = 0; r < n; ++r) {
    const auto& rd = d_.robots[r];
    for (std::size_t i = 0; i < rd.odometry.size(); ++i) events.push_back({rd.odometry[i].t, r, 0, i});
    if (o_.mode == MrclamOptions::Mode::kDeadReckoning) continue;
    for (std::size_t i = 0; i < rd.measurements.size(); ++i) {
      if (i > 0 && rd.measurements[i].t == rd.measurements[i - 1].t) continue;  // one event per image
      events.push_back({rd.measurements[i].t, r, 1, i});
    }
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });

  for (const Event& e : events) {
    if (e.t > t_end) break;
    RobotRun& rr = robots_[e.robot];
    if (!rr.in_filter && e.t >= d_.robots[e.robot].groundtruth.front().t) join_at_groundtruth(e.robot);
    if (e.t < t0_ || !rr.in_filter) {
      if (e.kind == 0) {  // keep the velocity that holds when the robot starts
        rr.v = d_.robots[e.robot].odometry[e.index].v;
        rr.w = d_.robots[e.robot].odometry[e.index].w;
      }
      continue;
    }
    predict(e.robot, e.t);
    if (e.kind == 0) {
      robots_[e.robot].v = d_.robots[e.robot].odometry[e.index].v;
      robots_[e.robot].w = d_.robots[e.robot].odometry[e.index].w;
      sample(e.robot, e.t);
    } else {
      const auto& ms = d_.robots[e.robot].measurements;
      std::size_t last = e.index;
      while (last < ms.size() && ms[last].t == e.t) ++last;
      measure(e.robot, e.t, e.index, last);
    }
  }

  // ---- results
  res_.mode = mode_name(o_.mode);
  res_.association = association_name(o_.association);
  res_.unknown_barcodes_dropped = d_.unknown_barcodes_dropped;
  res_.duration_s = t_end - t0_;
  double sum = 0;
  int with_gt = 0;
  for (int r = 0; r < n; ++r) {
    MrclamRobotResult rr;
    rr.robot = r + 1;
    rr.samples = robots_[r].n;
    rr.localized = robots_[r].localized;
    rr.localized_at = robots_[r].localized_at;
    if (robots_[r].n > 0) {
      rr.rmse_xy = std::sqrt(robots_[r].sq / static_cast<double>(robots_[r].n));
      rr.nees_mean = robots_[r].nees / static_cast<double>(robots_[r].n);
      sum += rr.rmse_xy;
      ++with_gt;
    }
    res_.robots.push_back(rr);
  }
  if (with_gt) res_.rmse_xy_mean = sum / with_gt;

  // Landmarks: each feature takes the majority label of its observations; per label the
  // feature with most observations is the match (others are duplicates or clutter).
  std::vector<Vec2> est, truth;
  double sq_unaligned = 0;
  for (std::size_t fi = 0; fi < filters_.size(); ++fi) {
    std::map<int, std::pair<int, FeatureId>> best;  // label -> (count, feature)
    for (const auto& [id, st] : feature_stats_[fi]) {
      if (!filters_[fi].has_feature(id)) continue;
      ++res_.features;
      int label = 0, count = 0, total = 0;
      for (const auto& [l, c] : st.labels) {
        total += c;
        if (c > count) {
          count = c;
          label = l;
        }
      }
      res_.association_errors += static_cast<std::size_t>(total - count);
      if (count > best[label].first) best[label] = {count, id};
    }
    std::vector<Vec2> e_i, t_i;
    for (const auto& [label, cf] : best) {
      auto it = d_.landmarks.find(label);
      if (it == d_.landmarks.end()) continue;
      e_i.push_back(filters_[fi].feature(cf.second));
      t_i.push_back(it->second);
      if (fi == 0) res_.map.emplace_back(label, e_i.back());
      sq_unaligned += (e_i.back() - t_i.back()).squaredNorm();
    }
    if (e_i.size() >= 2) {
      const Pose2 T = align_points(e_i, t_i);
      if (fi == 0) res_.alignment = T;
      for (std::size_t k = 0; k < e_i.size(); ++k) {
        est.push_back(transform_point(T, e_i[k]));
        truth.push_back(t_i[k]);
      }
    }
  }
  res_.landmarks_matched = est.size();
  if (!res_.map.empty()) {
    std::vector<Vec2> e, g;
    std::vector<int> gl, nn;
    for (const auto& [label, p] : res_.map) e.push_back(p);
    for (const auto& [label, p] : d_.landmarks) {
      g.push_back(p);
      gl.push_back(label);
    }
    res_.landmark_rmse_label_free = label_free_fit(e, g, &nn);
    for (std::size_t i = 0; i < res_.map.size() && !nn.empty(); ++i) {
      if (gl[nn[i]] != res_.map[i].first) res_.label_mismatches.emplace_back(res_.map[i].first, gl[nn[i]]);
    }
  }
  if (!est.empty()) {
    double sq = 0;
    for (std::size_t k = 0; k < est.size(); ++k) sq += (est[k] - truth[k]).squaredNorm();
    res_.landmark_rmse_aligned = std::sqrt(sq / static_cast<double>(est.size()));
    res_.landmark_rmse_unaligned = std::sqrt(sq_unaligned / static_cast<double>(est.size()));
  }
  res_.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return res_;
}

}  // namespace

MrclamResult run_mrclam(const MrclamData& data, const MrclamOptions& options) {
  Runner runner(data, options);
  return runner.run();
}

}  // namespace cairn::ccml
