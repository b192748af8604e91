#include "tools/datasets/mrclam_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace cairn::ccml {

namespace {

constexpr double kMadToSigma = 1.4826;  // σ of a normal distribution = 1.4826 × its median absolute deviation

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double robust_sigma(const std::vector<double>& residuals) {
  std::vector<double> a(residuals.size());
  std::transform(residuals.begin(), residuals.end(), a.begin(), [](double e) { return std::abs(e); });
  return kMadToSigma * median(std::move(a));
}

// Non-negative least squares of y ≈ a·u + b·v (two unknowns): the unconstrained solution,
// or the better of the two one-term fits when it has a negative part.
std::pair<double, double> nnls2(const std::vector<double>& u, const std::vector<double>& v, const std::vector<double>& y) {
  double uu = 0, uv = 0, vv = 0, uy = 0, vy = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    uu += u[i] * u[i];
    uv += u[i] * v[i];
    vv += v[i] * v[i];
    uy += u[i] * y[i];
    vy += v[i] * y[i];
  }
  const double det = uu * vv - uv * uv;
  if (det > 0) {
    const double a = (uy * vv - vy * uv) / det, b = (vy * uu - uy * uv) / det;
    if (a >= 0 && b >= 0) return {a, b};
  }
  const double a_only = uu > 0 ? std::max(0.0, uy / uu) : 0, b_only = vv > 0 ? std::max(0.0, vy / vv) : 0;
  double ra = 0, rb = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    ra += std::pow(y[i] - a_only * u[i], 2);
    rb += std::pow(y[i] - b_only * v[i], 2);
  }
  return ra <= rb ? std::pair{a_only, 0.0} : std::pair{0.0, b_only};
}

void fit_measurements(const MrclamData& d, double t0, double t1, MrclamNoiseFit* fit) {
  std::vector<double> er, eb;
  for (const auto& rd : d.robots) {
    std::size_t hint = 0;
    for (const MrclamMeasurement& m : rd.measurements) {
      if (m.t < t0 || m.t >= t1) continue;
      const auto lm = d.landmarks.find(m.subject);
      if (lm == d.landmarks.end()) continue;  // a robot, or a landmark without a surveyed position
      const auto pose = interpolate_groundtruth(rd.groundtruth, m.t, &hint);
      if (!pose) continue;
      const RangeBearing z = observe_point(*pose, lm->second);
      er.push_back(m.range - z.range);
      eb.push_back(normalize_angle(m.bearing - z.bearing));
    }
  }
  if (er.size() < 100) throw std::invalid_argument("MRCLAM calibration: fewer than 100 landmark sightings with ground truth in the window");
  fit->measurements = er.size();
  fit->range_median = median(er);
  fit->bearing_median = median(eb);
  fit->range_sigma = robust_sigma(er);
  fit->bearing_sigma = robust_sigma(eb);
}

// Per window: the squared residual of x and of heading, and the regressors of the filter's
// per-step model summed over the window (relative term with unit coefficient, and dt).
struct OdometryWindows {
  std::vector<double> ex2, eth2, x_rel, th_rel, dt;
};

void collect_windows(const MrclamRobotData& rd, double t0, double t1, double window_s, OdometryWindows* w) {
  MrclamOptions unit;  // coefficients 1 (relative) and 0 (rate): the step's relative terms alone
  unit.odom_v_rel = unit.odom_w_rel = 1;
  unit.odom_v_rate = unit.odom_w_rate = 0;
  std::size_t hint_a = 0, hint_b = 0;
  const auto& od = rd.odometry;
  std::size_t k = 0;
  while (k < od.size() && od[k].t < t0) ++k;
  while (k + 1 < od.size()) {
    const double ta = od[k].t;
    Pose2 odo{};
    double x_rel = 0, th_rel = 0;
    std::size_t j = k;
    // Zero-order hold, as the runs predict: record j's velocity holds until record j+1.
    while (j + 1 < od.size() && od[j + 1].t <= ta + window_s) {
      const double dt = od[j + 1].t - od[j].t;
      odo = compose(odo, arc_motion(od[j].v, od[j].w, dt));
      const Mat3 q = mrclam_odometry_cov(unit, od[j].v, od[j].w, dt);
      x_rel += q(0, 0);
      th_rel += q(2, 2);
      ++j;
    }
    const double tb = od[j].t;
    if (tb >= t1) break;
    k = j > k ? j : k + 1;
    if (tb - ta < 0.5 * window_s) continue;  // a gap in the odometry
    const auto ga = interpolate_groundtruth(rd.groundtruth, ta, &hint_a);
    const auto gb = interpolate_groundtruth(rd.groundtruth, tb, &hint_b);
    if (!ga || !gb) continue;
    const Pose2 truth = between(*ga, *gb);
    w->ex2.push_back(std::pow(truth.x - odo.x, 2));
    w->eth2.push_back(std::pow(normalize_angle(truth.theta - odo.theta), 2));
    w->x_rel.push_back(x_rel);
    w->th_rel.push_back(th_rel);
    w->dt.push_back(tb - ta);
  }
}

double mean_nees(const MrclamResult& r) {
  double sum = 0;
  int n = 0;
  for (const auto& x : r.robots) {
    if (x.nees_mean < 0) continue;
    sum += x.nees_mean;
    ++n;
  }
  return n ? sum / n : -1;
}

}  // namespace

void apply_noise(const MrclamNoiseFit& fit, MrclamOptions* o) {
  o->range_sigma = fit.range_sigma;
  o->bearing_sigma = fit.bearing_sigma;
  o->odom_v_rel = fit.odometry_factor * fit.odom_v_rel;
  o->odom_v_rate = fit.odometry_factor * fit.odom_v_rate;
  o->odom_w_rel = fit.odometry_factor * fit.odom_w_rel;
  o->odom_w_rate = fit.odometry_factor * fit.odom_w_rate;
}

MrclamNoiseFit calibrate_mrclam(const MrclamData& data, double until_s, double window_s) {
  if (!data.has_robot_groundtruth()) throw std::invalid_argument("MRCLAM calibration needs robot ground truth (" + data.dir + " has none)");
  if (!(until_s > 0) || !(window_s > 0)) throw std::invalid_argument("MRCLAM calibration: the window and its length must be positive");
  MrclamNoiseFit fit;
  fit.until_s = until_s;
  fit.window_s = window_s;
  const double t0 = mrclam_start(data), t1 = t0 + until_s;
  fit_measurements(data, t0, t1, &fit);

  OdometryWindows w;
  for (const auto& rd : data.robots) collect_windows(rd, t0, t1, window_s, &w);
  if (w.dt.size() < 50) throw std::invalid_argument("MRCLAM calibration: fewer than 50 odometry windows with ground truth");
  fit.odometry_windows = w.dt.size();
  const auto [vr2, vf2] = nnls2(w.x_rel, w.dt, w.ex2);
  const auto [wr2, wf2] = nnls2(w.th_rel, w.dt, w.eth2);
  fit.odom_v_rel = std::sqrt(vr2);
  fit.odom_v_rate = std::sqrt(vf2);
  fit.odom_w_rel = std::sqrt(wr2);
  fit.odom_w_rate = std::sqrt(wf2);

  // Step 3: the factor whose labelled cooperative run over the window is most consistent.
  double best = 1e300;
  for (int step = -2; step <= 8; ++step) {  // 0.5 to 16 in steps of √2
    const double f = std::pow(std::sqrt(2.0), step);
    MrclamNoiseFit trial = fit;
    trial.odometry_factor = f;
    MrclamOptions o;
    apply_noise(trial, &o);
    o.duration = until_s;
    const double nees = mean_nees(run_mrclam(data, o));
    const double miss = nees > 0 ? std::abs(std::log(nees / 3.0)) : 1e300;
    if (miss < best) {
      best = miss;
      fit.odometry_factor = f;
      fit.calibration_nees = nees;
    }
  }
  if (fit.calibration_nees < 0) throw std::invalid_argument("MRCLAM calibration: no run over the window was scored (no NEES)");
  return fit;
}

}  // namespace cairn::ccml
