// A deterministic stream of OdometryIncrement and FeatureObservations
// messages from robots driving circles among retroreflective poles, observing the
// poles and each other (range-bearing with noise), as a robot fleet would publish.
#pragma once

#include <cstdint>
#include <random>
#include <variant>
#include <vector>

#include "common/messages.hpp"
#include "common/se2.hpp"

namespace cairn::fleet_stream {

using FleetMessage = std::variant<msg::OdometryIncrement, msg::FeatureObservations>;

struct FleetScenario {
  std::vector<Vec2> poles;
  std::vector<Pose2> starts;       // true global start pose of each robot (robot i has id i+1)
  std::vector<Pose2> truth_end;    // true global pose at the end
  std::vector<FleetMessage> messages;
};

inline FleetScenario make_fleet_scenario(int robots, int steps, std::uint64_t seed = 5, double dt = 0.1) {
  FleetScenario s;
  s.poles = {{4, 0}, {0, 5}, {-5, 1}, {-1, -4}, {6, 5}, {-6, -5}, {3, -6}, {-3, 6}, {8, -2}, {-8, 3}};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const double sr = 0.05, sb = 1.5 * std::numbers::pi / 180.0;  // range, bearing noise
  const double sd = 0.01, st = 0.005;                            // odometry noise per step
  std::vector<Pose2> truth, local;
  std::vector<std::uint32_t> odom_seq(robots, 0), feat_seq(robots, 0);
  for (int r = 0; r < robots; ++r) {
    s.starts.push_back({-2.0 + 2.0 * r, -1.0 + 0.5 * r, 0.3 * r});
    truth.push_back(s.starts.back());
    local.push_back({});
  }
  for (int k = 0; k < steps; ++k) {
    for (int r = 0; r < robots; ++r) {
      const Pose2 step{0.4 * dt, 0, (0.12 + 0.03 * r) * dt};  // circles of a few metres
      truth[r] = compose(truth[r], step);
      Pose2 measured{step.x + sd * g(rng), step.y + sd * g(rng), step.theta + st * g(rng)};
      local[r] = compose(local[r], measured);
      msg::OdometryIncrement o{};
      o.robot_id = static_cast<std::uint16_t>(r + 1);
      o.seq = ++odom_seq[r];
      o.t0 = static_cast<std::int64_t>(k * dt * 1e9);
      o.t1 = static_cast<std::int64_t>((k + 1) * dt * 1e9);
      o.delta = measured;
      o.delta_cov[0] = o.delta_cov[4] = sd * sd;
      o.delta_cov[8] = st * st;
      o.local_pose = local[r];
      s.messages.emplace_back(o);
      if (k % 2 != 0) continue;  // features at half the odometry rate
      msg::FeatureObservations f{};
      f.robot_id = o.robot_id;
      f.seq = ++feat_seq[r];
      f.stamp = o.t1;
      f.local_pose = o.local_pose;
      f.odom_seq = o.seq;
      auto add = [&](const Vec2& p, msg::FeatureKind kind, long marker) {
        RangeBearing z = observe_point(truth[r], p);
        if (z.range > 7.0 || z.range < 0.3 || f.n_features >= msg::kMaxFeatures) return;
        msg::Feature& ft = f.features[f.n_features++];
        ft.kind = kind;
        ft.marker_id = static_cast<std::int32_t>(marker);
        ft.range = z.range + sr * g(rng);
        ft.bearing = normalize_angle(z.bearing + sb * g(rng));
        ft.cov[0] = sr * sr;
        ft.cov[3] = sb * sb;
      };
      for (const Vec2& p : s.poles) add(p, msg::FeatureKind::kLandmark, -1);
      for (int q = 0; q < robots; ++q) {
        if (q != r) add(truth[q].translation(), msg::FeatureKind::kRobot, q + 1);
      }
      s.messages.emplace_back(f);
    }
  }
  s.truth_end = truth;
  return s;
}

/// Feeds one message to anything with on_odometry / on_features (the base's Fusion).
template <typename Sink>
void feed(Sink* sink, const FleetMessage& m) {
  if (const auto* od = std::get_if<msg::OdometryIncrement>(&m)) sink->on_odometry(*od);
  else sink->on_features(std::get<msg::FeatureObservations>(m));
}

}  // namespace cairn::fleet_stream
