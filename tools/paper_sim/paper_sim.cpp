#include "tools/paper_sim/paper_sim.hpp"

#include "basestation/ccml/bounds.hpp"

#include <cmath>
#include <map>
#include <random>

namespace cairn::ccml {

std::vector<Vec2> paper_features() { return {{8, 0}, {0, 8}, {-8, 0}, {0, -8}}; }

PaperScenario PaperScenario::table(int scenario, int vehicles) {
  PaperScenario s;
  s.scenario = scenario;
  s.vehicles = vehicles;
  if (scenario == 2) {
    s.process_sigma_rate = Vec3(0.2, 0.25, 0.2 * std::numbers::pi / 180.0);
    s.initial_sigma = Vec3(0.075, 0.075, 0.0);
  }
  return s;
}

namespace {

// A vehicle driving around a square (corners counter-clockwise) at constant speed.
struct SquareDriver {
  double half;
  int leg = 0;       // heading for corner leg+1
  Pose2 pose;

  static Vec2 corner(double h, int i) {
    static const int sx[4] = {1, -1, -1, 1}, sy[4] = {1, 1, -1, -1};
    return {h * sx[i % 4], h * sy[i % 4]};
  }
  explicit SquareDriver(double h, int start_corner) : half(h), leg(start_corner) {
    const Vec2 c = corner(h, start_corner), next = corner(h, start_corner + 1);
    pose = {c.x(), c.y(), std::atan2(next.y() - c.y(), next.x() - c.x())};
  }
  void step(double dist) {
    while (dist > 1e-12) {
      const Vec2 target = corner(half, leg + 1);
      const Vec2 d = target - pose.translation();
      const double left = d.norm();
      if (left <= dist) {
        pose.x = target.x();
        pose.y = target.y();
        dist -= left;
        ++leg;
        const Vec2 nxt = corner(half, leg + 1) - target;
        pose.theta = std::atan2(nxt.y(), nxt.x());
      } else {
        pose.x += d.x() / left * dist;
        pose.y += d.y() / left * dist;
        dist = 0;
      }
    }
  }
};

Mat2 position_block(const Mat3& c) { return c.topLeftCorner<2, 2>(); }

}  // namespace

PaperRun run_paper_simulation(const PaperScenario& s) {
  std::mt19937_64 rng(s.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double bearing_sigma = s.bearing_sigma_deg * std::numbers::pi / 180.0;
  Mat2 R = Mat2::Zero();
  R(0, 0) = s.range_sigma * s.range_sigma;
  R(1, 1) = bearing_sigma * bearing_sigma;
  const Vec3 q_sigma = s.process_sigma_rate * s.dt;
  const Mat3 Q = q_sigma.cwiseAbs2().asDiagonal();
  const Mat3 P0 = s.initial_sigma.cwiseAbs2().asDiagonal();

  const std::vector<Vec2> features = paper_features();
  std::vector<SquareDriver> truth = {SquareDriver(6.0, 0), SquareDriver(3.0, 2), SquareDriver(4.5, 1)};
  const int total_vehicles = s.vehicles + (s.third_vehicle_at ? 1 : 0);
  truth.resize(static_cast<std::size_t>(total_vehicles), SquareDriver(4.5, 1));

  CcmlFilter f(64);
  auto sample_initial = [&](const Pose2& p, const Vec3& sigma) {
    return Pose2{p.x + sigma.x() * gauss(rng), p.y + sigma.y() * gauss(rng), p.theta + sigma.z() * gauss(rng)};
  };
  for (int v = 0; v < s.vehicles; ++v) f.add_robot(static_cast<RobotId>(v), sample_initial(truth[v].pose, s.initial_sigma), P0);

  std::map<int, FeatureId> feature_of;  // true feature index -> filter id
  PaperRun run;
  run.scenario = s;
  std::vector<Mat2> initial_infos = {};
  for (int v = 0; v < s.vehicles; ++v) initial_infos.push_back(position_block(P0));

  {
    PaperSample s0;
    s0.det_vehicle_a = position_block(f.robot_cov(0)).determinant();
    run.samples.push_back(s0);
  }
  const int steps = static_cast<int>(std::lround(s.duration / s.dt));
  bool third_joined = false;
  for (int k = 1; k <= steps; ++k) {
    const double t = k * s.dt;
    if (s.third_vehicle_at && !third_joined && t >= *s.third_vehicle_at) {
      const Mat3 Pj = s.join_sigma.cwiseAbs2().asDiagonal();
      f.add_robot(static_cast<RobotId>(s.vehicles), sample_initial(truth[s.vehicles].pose, s.join_sigma), Pj);
      initial_infos.push_back(position_block(Pj));
      third_joined = true;
    }
    const int active = s.vehicles + (third_joined ? 1 : 0);
    // Motion: truth moves; the filter predicts with the noisy odometry increment.
    for (int v = 0; v < total_vehicles; ++v) {
      const Pose2 before = truth[v].pose;
      truth[v].step(s.speed * s.dt);
      if (v >= active) continue;
      Pose2 delta = between(before, truth[v].pose);
      delta.x += q_sigma.x() * gauss(rng);
      delta.y += q_sigma.y() * gauss(rng);
      delta.theta += q_sigma.z() * gauss(rng);
      f.predict(static_cast<RobotId>(v), delta, Q);
    }
    // Observations (known association, as in the paper's simulation).
    std::vector<Measurement> batch;
    auto noisy = [&](const Pose2& from, const Vec2& p) {
      RangeBearing z = observe_point(from, p);
      z.range += s.range_sigma * gauss(rng);
      z.bearing = normalize_angle(z.bearing + bearing_sigma * gauss(rng));
      return z;
    };
    for (int v = 0; v < active; ++v) {
      const Pose2& pv = truth[v].pose;
      for (std::size_t j = 0; j < features.size(); ++j) {
        if ((features[j] - pv.translation()).norm() > s.max_range) continue;
        const RangeBearing z = noisy(pv, features[j]);
        auto it = feature_of.find(static_cast<int>(j));
        if (it == feature_of.end()) {
          feature_of[static_cast<int>(j)] = f.add_feature(static_cast<RobotId>(v), z, R);
          continue;
        }
        batch.push_back({static_cast<RobotId>(v), Measurement::Target::kFeature, it->second, z, R});
      }
      if (!s.robot_observations) continue;
      for (int w = 0; w < active; ++w) {
        if (w == v || (truth[w].pose.translation() - pv.translation()).norm() > s.max_range) continue;
        batch.push_back({static_cast<RobotId>(v), Measurement::Target::kRobot, static_cast<std::uint32_t>(w),
                         noisy(pv, truth[w].pose.translation()), R});
      }
    }
    const UpdateResult u = f.update(batch, s.update_iterations);

    PaperSample smp;
    smp.t = t;
    const Mat3 Pa = f.robot_cov(0);
    smp.det_vehicle_a = position_block(Pa).determinant();
    if (feature_of.count(0)) smp.det_feature_1 = f.feature_cov(feature_of[0]).determinant();
    const Pose2 ea = f.robot_pose(0);
    Vec3 err(ea.x - truth[0].pose.x, ea.y - truth[0].pose.y, normalize_angle(ea.theta - truth[0].pose.theta));
    if (Pa(2, 2) > 1e-12) {
      smp.nees_a = err.dot(Pa.ldlt().solve(err));
      smp.nees_dof = 3;
    } else {
      smp.nees_a = err.head<2>().dot(Pa.topLeftCorner<2, 2>().ldlt().solve(err.head<2>()));
      smp.nees_dof = 2;
    }
    smp.nis = u.nis;
    smp.nis_dof = u.dof;
    run.samples.push_back(smp);
  }

  // Bound: single vehicle -> its own initial covariance (Theorem III.3); team -> eq. 5 / 7.
  run.bound_det = cooperative_bound(initial_infos).determinant();
  const int active = s.vehicles + (third_joined ? 1 : 0);
  for (int v = 0; v < active; ++v) {
    run.true_vehicles.push_back(truth[v].pose);
    run.est_vehicles.push_back(f.robot_pose(static_cast<RobotId>(v)));
    run.vehicle_covs.push_back(position_block(f.robot_cov(static_cast<RobotId>(v))));
  }
  for (const auto& [j, id] : feature_of) {
    run.true_features.push_back(features[j]);
    run.est_features.push_back(f.feature(id));
    run.feature_covs.push_back(f.feature_cov(id));
  }
  run.min_eigenvalue = f.min_eigenvalue();
  run.max_asymmetry = f.max_asymmetry();
  return run;
}

}  // namespace cairn::ccml
