// cairn-bench-ccml-mrpt: Cairn's CCML filter beside MRPT's range-bearing EKF-SLAM
// (mrpt::slam::CRangeBearingKFSLAM2D, Debian libmrpt-dev) in one run.
//  A. update time per step (predict + 8 known-ID observations) on synthetic maps of
//     50 / 200 / 500 features: median of many steps, and the MRPT/Cairn ratio;
//  B. accuracy on real data: robot 1 of UTIAS MRCLAM Dataset 6, identical odometry
//     increments, noise and (labelled) observations fed to both; position RMSE vs
//     ground truth and run time.
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservationBearingRange.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/slam/CRangeBearingKFSLAM2D.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "basestation/ccml/filter.hpp"
#include "tools/datasets/mrclam.hpp"

using namespace cairn;
using namespace cairn::ccml;
using Clock = std::chrono::steady_clock;

namespace {

struct Noise {
  double sr = 0.1, sb = 0.02;
};

// One MRPT step: a Gaussian odometry action and a bearing-range observation with IDs.
void mrpt_step(mrpt::slam::CRangeBearingKFSLAM2D& slam, const Pose2& delta, const Mat3& Q,
               const std::vector<std::pair<int, RangeBearing>>& obs, const Noise& n) {
  auto actions = mrpt::obs::CActionCollection::Create();
  mrpt::obs::CActionRobotMovement2D act;
  mrpt::math::CMatrixDouble33 cov;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cov(r, c) = Q(r, c);
  }
  act.poseChange = mrpt::poses::CPosePDFGaussian::Create(mrpt::poses::CPose2D(delta.x, delta.y, delta.theta), cov);
  actions->insert(act);
  auto sf = mrpt::obs::CSensoryFrame::Create();
  auto o = mrpt::obs::CObservationBearingRange::Create();
  o->minSensorDistance = 0;
  o->maxSensorDistance = 1000;
  o->fieldOfView_yaw = static_cast<float>(2 * std::numbers::pi);
  o->validCovariances = false;
  o->sensor_std_range = static_cast<float>(n.sr);
  o->sensor_std_yaw = static_cast<float>(n.sb);
  o->sensor_std_pitch = 0;
  for (const auto& [id, z] : obs) {
    mrpt::obs::CObservationBearingRange::TMeasurement m;
    m.range = static_cast<float>(z.range);
    m.yaw = static_cast<float>(z.bearing);
    m.pitch = 0;
    m.landmarkID = id;
    o->sensedData.push_back(m);
  }
  sf->insert(o);
  slam.processActionObservation(actions, sf);
}

void configure_mrpt(mrpt::slam::CRangeBearingKFSLAM2D& slam, const Noise& n) {
  slam.options.std_sensor_range = static_cast<float>(n.sr);
  slam.options.std_sensor_yaw = static_cast<float>(n.sb);
  slam.KF_options.method = mrpt::bayes::kfEKFNaive;
  slam.setVerbosityLevel(mrpt::system::LVL_ERROR);
}

struct Timing {
  int features;
  double cairn_us, mrpt_us;
  double joseph_us = 0;  // Cairn's filter with the Joseph-form covariance update (its old form), same steps
  double cairn_err = 0, mrpt_err = 0;  // final robot position error (m)
};

Timing time_update(int n_features, int steps, std::uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-40, 40);
  std::normal_distribution<double> g(0, 1);
  const Noise noise;
  std::vector<Vec2> lm(n_features);
  for (auto& p : lm) p = {u(rng), u(rng)};
  const Mat2 R = Vec2(noise.sr * noise.sr, noise.sb * noise.sb).asDiagonal();
  const Mat3 Q = Vec3(1e-4, 1e-4, 1e-5).asDiagonal();

  CcmlFilter cairn_f(static_cast<std::size_t>(3 + 2 * n_features));
  cairn_f.add_robot(1, {}, Mat3::Identity() * 1e-6);
  mrpt::slam::CRangeBearingKFSLAM2D mrpt_f;
  configure_mrpt(mrpt_f, noise);
  std::map<int, FeatureId> ids;
  // Warm-up: both filters initialise every landmark (seen from the origin, 25 at a time).
  for (int start = 0; start < n_features; start += 25) {
    std::vector<std::pair<int, RangeBearing>> obs;
    for (int i = start; i < std::min(n_features, start + 25); ++i) {
      const RangeBearing z = observe_point({}, lm[i]);
      obs.emplace_back(i, z);
      ids[i] = cairn_f.add_feature(1, z, R);
    }
    mrpt_step(mrpt_f, {}, Q, obs, noise);
  }
  // The same filter with the Joseph-form update, from the same state (same-run baseline).
  CcmlFilter joseph_f = cairn_f;
  joseph_f.set_covariance_update(CovarianceUpdate::kJoseph);
  // Timed steps: small motion, 8 known landmarks observed.
  Pose2 truth{};
  std::vector<double> tc, tm, tj;
  for (int k = 0; k < steps; ++k) {
    const Pose2 delta{0.05, 0, 0.01};
    truth = compose(truth, delta);
    std::vector<std::pair<int, RangeBearing>> obs;
    std::vector<Measurement> ms;
    for (int j = 0; j < 8; ++j) {
      const int i = static_cast<int>((k * 8 + j * 7) % n_features);
      RangeBearing z = observe_point(truth, lm[i]);
      z.range += noise.sr * g(rng);
      z.bearing = normalize_angle(z.bearing + noise.sb * g(rng));
      obs.emplace_back(i, z);
      ms.push_back({1, Measurement::Target::kFeature, ids[i], z, R});
    }
    auto t0 = Clock::now();
    cairn_f.predict(1, delta, Q);
    cairn_f.update(ms);
    auto t1 = Clock::now();
    mrpt_step(mrpt_f, delta, Q, obs, noise);
    auto t2 = Clock::now();
    joseph_f.predict(1, delta, Q);
    joseph_f.update(ms);
    auto t3 = Clock::now();
    tc.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    tm.push_back(std::chrono::duration<double, std::micro>(t2 - t1).count());
    tj.push_back(std::chrono::duration<double, std::micro>(t3 - t2).count());
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  Timing t{n_features, median(tc), median(tm)};
  t.joseph_us = median(tj);
  const Pose2 ce = cairn_f.robot_pose(1);
  mrpt::poses::CPosePDFGaussian mp;
  mrpt_f.getCurrentRobotPose(mp);
  t.cairn_err = std::hypot(ce.x - truth.x, ce.y - truth.y);
  t.mrpt_err = std::hypot(mp.mean.x() - truth.x, mp.mean.y() - truth.y);
  return t;
}

struct Accuracy {
  double cairn_rmse = -1, mrpt_rmse = -1, cairn_s = 0, mrpt_s = 0;
  std::size_t steps = 0;
};

// Robot 1 of an MRCLAM dataset, labelled landmarks, identical inputs to both filters.
Accuracy mrclam_robot1(const std::string& dir) {
  const MrclamData d = load_mrclam(dir);
  const auto& rd = d.robots[0];
  const Noise noise{0.15, 0.06};
  const Mat2 R = Vec2(noise.sr * noise.sr, noise.sb * noise.sb).asDiagonal();
  std::size_t gi = 0;
  auto gt_at = [&](double t) -> std::optional<Pose2> {
    const auto& gt = rd.groundtruth;
    if (gt.empty() || t < gt.front().t || t > gt.back().t) return std::nullopt;
    while (gi + 1 < gt.size() && gt[gi + 1].t < t) ++gi;
    return Pose2{gt[gi].x, gt[gi].y, gt[gi].theta};
  };
  const double t0 = rd.groundtruth.front().t;
  const Pose2 start = *gt_at(t0);
  CcmlFilter cf;
  cf.add_robot(1, start, Vec3(4e-4, 4e-4, 4e-4).asDiagonal());
  mrpt::slam::CRangeBearingKFSLAM2D mf;
  configure_mrpt(mf, noise);
  // MRPT starts at (0,0,0): feed it the robot-frame problem and compare after composing with the start.
  std::map<int, FeatureId> ids;
  Pose2 delta{};
  Mat3 Q = Mat3::Zero();
  double v = 0, w = 0, t_last = t0;
  std::size_t oi = 0, mi = 0;
  double sq_c = 0, sq_m = 0;
  Accuracy acc;
  auto integrate = [&](double t) {
    const double dt = t - t_last;
    if (dt <= 0) return;
    t_last = t;
    const Pose2 step = arc_motion(v, w, dt);
    Mat3 J1, J2;
    compose_jacobians(delta, step, &J1, &J2);
    const double sx = 0.15 * std::abs(v * dt), st = 0.4 * std::abs(w * dt) + 0.015 * std::abs(v * dt);
    const Mat3 q = Vec3(sx * sx + 9e-4 * dt, 0.01 * sx * sx + 2.25e-4 * dt, st * st + 0.0225 * dt).asDiagonal();
    Q = J1 * Q * J1.transpose() + J2 * q * J2.transpose();
    delta = compose(delta, step);
  };
  while (mi < rd.measurements.size()) {
    const double tm = rd.measurements[mi].t;
    while (oi < rd.odometry.size() && rd.odometry[oi].t <= tm) {
      if (rd.odometry[oi].t >= t0) integrate(rd.odometry[oi].t);
      v = rd.odometry[oi].v;
      w = rd.odometry[oi].w;
      ++oi;
    }
    if (tm < t0) {
      ++mi;
      continue;
    }
    integrate(tm);
    std::vector<std::pair<int, RangeBearing>> obs;
    std::vector<Measurement> ms;
    std::vector<std::pair<int, RangeBearing>> fresh;
    for (; mi < rd.measurements.size() && rd.measurements[mi].t == tm; ++mi) {
      const auto& m = rd.measurements[mi];
      if (m.subject <= 5) continue;
      const RangeBearing z{m.range, normalize_angle(m.bearing)};
      obs.emplace_back(m.subject, z);
      if (ids.count(m.subject)) {
        ms.push_back({1, Measurement::Target::kFeature, ids[m.subject], z, R});
      } else {
        fresh.emplace_back(m.subject, z);
      }
    }
    if (!gt_at(tm)) break;
    auto c0 = Clock::now();
    cf.predict(1, delta, Q);
    cf.update(ms);
    for (const auto& [s, z] : fresh) ids[s] = cf.add_feature(1, z, R);
    auto c1 = Clock::now();
    if (!obs.empty()) mrpt_step(mf, delta, Q, obs, noise);
    auto c2 = Clock::now();
    acc.cairn_s += std::chrono::duration<double>(c1 - c0).count();
    acc.mrpt_s += std::chrono::duration<double>(c2 - c1).count();
    delta = {};
    Q.setZero();
    const Pose2 gt = *gt_at(tm);
    const Pose2 ce = cf.robot_pose(1);
    mrpt::poses::CPosePDFGaussian mp;
    mf.getCurrentRobotPose(mp);
    const Pose2 me = compose(start, Pose2{mp.mean.x(), mp.mean.y(), mp.mean.phi()});
    sq_c += std::pow(ce.x - gt.x, 2) + std::pow(ce.y - gt.y, 2);
    sq_m += std::pow(me.x - gt.x, 2) + std::pow(me.y - gt.y, 2);
    ++acc.steps;
  }
  acc.cairn_rmse = std::sqrt(sq_c / static_cast<double>(acc.steps));
  acc.mrpt_rmse = std::sqrt(sq_m / static_cast<double>(acc.steps));
  return acc;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-bench-ccml-mrpt: Cairn's CCML EKF beside MRPT's CRangeBearingKFSLAM2D (update time, accuracy)"};
  int steps = 200;
  std::string dataset;
  bool json = false;
  app.add_option("--steps", steps, "timed steps per map size");
  app.add_option("--mrclam", dataset, "MRCLAM dataset directory for the accuracy comparison (robot 1)");
  app.add_flag("--json", json, "print JSON");
  CLI11_PARSE(app, argc, argv);
  nlohmann::json out = {{"timing", nlohmann::json::array()}};
  if (!json) {
    std::printf("%-10s %14s %14s %10s %14s %14s %14s %12s\n", "features", "cairn (us)", "mrpt (us)", "mrpt/cairn", "cairn err (m)",
                "mrpt err (m)", "joseph (us)", "joseph/cairn");
  }
  for (int n : {50, 200, 500}) {
    const Timing t = time_update(n, steps, 7);
    out["timing"].push_back({{"features", n}, {"cairn_us", t.cairn_us}, {"mrpt_us", t.mrpt_us}, {"ratio", t.mrpt_us / t.cairn_us},
                             {"cairn_error_m", t.cairn_err}, {"mrpt_error_m", t.mrpt_err},
                             {"cairn_joseph_us", t.joseph_us}, {"joseph_over_cairn", t.joseph_us / t.cairn_us}});
    if (!json) {
      std::printf("%-10d %14.1f %14.1f %10.1f %14.3f %14.3f %14.1f %12.2f\n", n, t.cairn_us, t.mrpt_us, t.mrpt_us / t.cairn_us,
                  t.cairn_err, t.mrpt_err, t.joseph_us, t.joseph_us / t.cairn_us);
    }
    std::fflush(stdout);
  }
  if (!dataset.empty()) {
    const Accuracy a = mrclam_robot1(dataset);
    out["mrclam_robot1"] = {{"steps", a.steps}, {"cairn_rmse_m", a.cairn_rmse}, {"mrpt_rmse_m", a.mrpt_rmse},
                            {"cairn_s", a.cairn_s}, {"mrpt_s", a.mrpt_s}};
    if (!json) {
      std::printf("\nMRCLAM robot 1 (%zu steps, labelled landmarks, identical inputs):\n", a.steps);
      std::printf("  position RMSE  cairn %.3f m   mrpt %.3f m\n", a.cairn_rmse, a.mrpt_rmse);
      std::printf("  filter time    cairn %.3f s   mrpt %.3f s   (mrpt/cairn %.1f)\n", a.cairn_s, a.mrpt_s, a.mrpt_s / a.cairn_s);
    }
  }
  if (json) std::printf("%s\n", out.dump(2).c_str());
  return 0;
}
