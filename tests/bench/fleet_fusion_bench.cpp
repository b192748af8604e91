// Twenty robots in real time: the base's Fusion (the production class, without its DDS
// edge) fed by a fleet at its real rates, on the wall clock, with a few hundred landmarks.
//
// World: `--landmarks` poles on a jittered grid 5 m apart. Each robot drives a circle of
// 6 m radius at 0.5 m/s around its own centre (a 5 × 4 grid of centres across the field)
// and sends, per scan (`--scan-hz`, 37.5), one OdometryIncrement and, at most once per
// `--feature-period` s (0: every scan), one FeatureObservations with the poles within 8 m
// (σ 5 cm, 1°), marker-less: the base associates them by JCBB. The robots are known at
// their true start poses, so the map frame is the truth's.
//
// First `--warmup` seconds of the stream are fed as fast as possible (the map fills up),
// then `--seconds` are replayed paced: message k is due at its stamp on the wall clock;
// one thread takes each when due (or at once when behind) and applies it, as the base's
// fusion thread does with what DDS delivers. Lag = applied − due. CPU = that thread's
// CPU time over the paced wall time. The baseline in the same run is the same stream
// into a Fusion with the expanded Joseph covariance update.
//
// The exit status is the verdict on the symmetric (default) run: 1 when the max lag
// exceeds --max-lag-s (1 s), the landmarks are outside [95 %, 102 %] of the poles the
// robots saw (pruning of poles seen once or twice allowed, duplicates not), the mean final
// position error exceeds --max-error-m (0.05 m; dead reckoning's is printed beside it), or
// Joseph / symmetric time per feature message is below --min-ratio (default: no bound).
//   build/ci/tests/bench/cairn-bench-fleet-fusion --robots 20 --landmarks 300 --seconds 20 --warmup 40 [--json]
#include <CLI/CLI.hpp>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "basestation/fusion.hpp"
#include "tests/support/percentile.hpp"

using namespace cairn;

namespace {

struct Stream {
  std::vector<Vec2> poles;
  std::vector<Pose2> starts, truth_end, dead_reckoning_end;  // dead reckoning: start ⊕ the robot's local pose
  std::vector<std::variant<msg::OdometryIncrement, msg::FeatureObservations>> messages;
  std::vector<Nanos> due;           // per message: its scan's stamp
  std::size_t first_paced = 0;      // index of the first message after the warm-up (= size: none paced)
  std::set<std::size_t> poles_seen;  // by the end of the stream
  std::set<std::size_t> poles_seen_warmup;
};

struct Options {
  int robots = 20;
  int landmarks = 300;
  double seconds = 20, warmup = 40, scan_hz = 37.5, feature_period = 0, max_lag_s = 1.0, max_error_m = 0.05;
  double min_ratio = 0;  // Joseph / symmetric time per feature message, below which the run fails (0: no bound)
  std::uint64_t seed = 3;
};

Stream make_stream(const Options& o) {
  Stream s;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  const int cols = static_cast<int>(std::ceil(std::sqrt(o.landmarks * 4.0 / 3.0)));
  for (int k = 0; k < o.landmarks; ++k) {
    s.poles.emplace_back(5.0 * (k % cols) + jitter(rng), 5.0 * (k / cols) + jitter(rng));
  }
  const int rows = (o.landmarks + cols - 1) / cols;
  const double width = 5.0 * (cols - 1), height = 5.0 * (rows - 1);
  const int ccols = 5, crows = (o.robots + ccols - 1) / ccols;
  const double radius = 6.0, speed = 0.5, dt = 1.0 / o.scan_hz;
  const double sr = 0.05, sb = std::numbers::pi / 180.0, range_max = 8.0;
  const double sd = 0.002, st = 0.001;  // odometry noise per scan step
  std::vector<Pose2> truth, local;
  std::vector<std::uint32_t> odom_seq(static_cast<std::size_t>(o.robots), 0), feat_seq(odom_seq);
  std::vector<Nanos> last_features(odom_seq.size(), -1);
  for (int r = 0; r < o.robots; ++r) {
    const double cx = width * (0.5 + r % ccols) / ccols, cy = height * (0.5 + r / ccols) / crows;
    const double phase = 2.0 * std::numbers::pi * r / o.robots;  // start on the circle, heading along it
    s.starts.push_back({cx + radius * std::cos(phase), cy + radius * std::sin(phase), phase + std::numbers::pi / 2});
    truth.push_back(s.starts.back());
    local.push_back({});
  }
  const auto warmup_steps = static_cast<long>(std::llround(o.warmup * o.scan_hz));
  const auto steps = warmup_steps + std::max(1L, static_cast<long>(std::llround(o.seconds * o.scan_hz)));
  const Nanos period_ns = static_cast<Nanos>(o.feature_period * 1e9);
  for (long k = 0; k < steps; ++k) {
    const bool in_warmup = k < warmup_steps;
    if (k == warmup_steps) s.first_paced = s.messages.size();
    const Nanos t1 = static_cast<Nanos>(static_cast<double>(k + 1) * dt * 1e9);
    for (int r = 0; r < o.robots; ++r) {
      const auto ri = static_cast<std::size_t>(r);
      const Pose2 step{speed * dt, 0, speed / radius * dt};
      truth[ri] = compose(truth[ri], step);
      const Pose2 measured{step.x + sd * g(rng), step.y + sd * g(rng), step.theta + st * g(rng)};
      local[ri] = compose(local[ri], measured);
      msg::OdometryIncrement inc{};
      inc.robot_id = static_cast<std::uint16_t>(r + 1);
      inc.seq = ++odom_seq[ri];
      inc.t0 = t1 - static_cast<Nanos>(dt * 1e9);
      inc.t1 = t1;
      inc.delta = measured;
      inc.delta_cov[0] = inc.delta_cov[4] = sd * sd;
      inc.delta_cov[8] = st * st;
      inc.local_pose = local[ri];
      s.messages.emplace_back(inc);
      s.due.push_back(t1);
      if (last_features[ri] >= 0 && t1 - last_features[ri] < period_ns) continue;
      msg::FeatureObservations f{};
      f.robot_id = inc.robot_id;
      f.stamp = t1;
      f.local_pose = inc.local_pose;
      f.odom_seq = inc.seq;
      for (std::size_t p = 0; p < s.poles.size() && f.n_features < msg::kMaxFeatures; ++p) {
        const RangeBearing z = observe_point(truth[ri], s.poles[p]);
        // A 180° laser from 0.3 m (a robot's circle may pass through a pole here: nothing collides).
        if (z.range > range_max || z.range < 0.3 || std::abs(z.bearing) > std::numbers::pi / 2) continue;
        msg::Feature& ft = f.features[f.n_features++];
        ft.range = z.range + sr * g(rng);
        ft.bearing = normalize_angle(z.bearing + sb * g(rng));
        ft.cov[0] = sr * sr;
        ft.cov[3] = sb * sb;
        s.poles_seen.insert(p);
        if (in_warmup) s.poles_seen_warmup.insert(p);
      }
      if (f.n_features == 0) continue;
      f.seq = ++feat_seq[ri];
      last_features[ri] = t1;
      s.messages.emplace_back(f);
      s.due.push_back(t1);
    }
  }
  s.truth_end = truth;
  for (std::size_t r = 0; r < truth.size(); ++r) s.dead_reckoning_end.push_back(compose(s.starts[r], local[r]));
  return s;
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

using cairn::testing::percentile;

struct Figures {
  std::string name;
  double wall_s = 0, cpu_share = 0, feature_us_mean = 0, odometry_us_mean = 0;
  double lag_p50_ms = 0, lag_p99_ms = 0, lag_max_s = 0;
  std::size_t feature_messages = 0, odometry_messages = 0, landmarks = 0, state_dim = 0;
  double updates_per_s = 0, error_mean_m = 0, error_max_m = 0, dead_reckoning_mean_m = 0;
  std::uint64_t rejected = 0;
  std::string rejected_reasons;
  std::uint64_t observations_used = 0;
};

Figures run(const std::string& name, const Stream& s, ccml::CovarianceUpdate form) {
  base::FusionConfig c;
  c.covariance_update = form;
  for (std::size_t r = 0; r < s.starts.size(); ++r) {
    base::RobotPrior p;
    p.known = true;
    p.pose = s.starts[r];
    p.sigma = Vec3(0.05, 0.05, 0.01);
    c.robots[static_cast<std::uint16_t>(r + 1)] = p;
  }
  base::Fusion fusion(c);
  auto apply = [&](std::size_t k) {
    return std::visit(
        [&](const auto& m) {
          if constexpr (std::is_same_v<std::decay_t<decltype(m)>, msg::OdometryIncrement>) {
            return (fusion.on_odometry(m), false);
          } else {
            return (fusion.on_features(m), true);
          }
        },
        s.messages[k]);
  };
  for (std::size_t k = 0; k < s.first_paced; ++k) apply(k);

  Figures f;
  f.name = name;
  using Clock = std::chrono::steady_clock;
  const Nanos t_first = s.due[s.first_paced];
  const auto start = Clock::now();
  const double cpu0 = thread_cpu_s();
  std::vector<double> lag_ms;
  lag_ms.reserve(s.messages.size() - s.first_paced);
  double feature_s = 0, odometry_s = 0;
  for (std::size_t k = s.first_paced; k < s.messages.size(); ++k) {
    const auto due = start + std::chrono::nanoseconds(s.due[k] - t_first);
    std::this_thread::sleep_until(due);
    const auto a = Clock::now();
    const bool features = apply(k);
    const auto b = Clock::now();
    const double took = std::chrono::duration<double>(b - a).count();
    (features ? feature_s : odometry_s) += took;
    ++(features ? f.feature_messages : f.odometry_messages);
    lag_ms.push_back(std::chrono::duration<double, std::milli>(b - due).count());
  }
  f.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  f.cpu_share = (thread_cpu_s() - cpu0) / f.wall_s;
  f.feature_us_mean = f.feature_messages ? 1e6 * feature_s / static_cast<double>(f.feature_messages) : 0;
  f.odometry_us_mean = f.odometry_messages ? 1e6 * odometry_s / static_cast<double>(f.odometry_messages) : 0;
  f.updates_per_s = static_cast<double>(f.feature_messages) / f.wall_s;
  f.lag_p50_ms = percentile(lag_ms, 0.50);
  f.lag_p99_ms = percentile(lag_ms, 0.99);
  f.lag_max_s = lag_ms.empty() ? 0 : *std::max_element(lag_ms.begin(), lag_ms.end()) * 1e-3;
  f.landmarks = fusion.filter().feature_count();
  f.state_dim = fusion.filter().dimension();
  f.rejected = fusion.counters().rejected.total();
  f.rejected_reasons = fusion.counters().rejected.summary();
  f.observations_used = fusion.counters().observations_used;
  for (std::size_t r = 0; r < s.truth_end.size(); ++r) {
    const Pose2 est = fusion.filter().robot_pose(static_cast<ccml::RobotId>(r + 1));
    const double e = std::hypot(est.x - s.truth_end[r].x, est.y - s.truth_end[r].y);
    f.error_mean_m += e / static_cast<double>(s.truth_end.size());
    f.error_max_m = std::max(f.error_max_m, e);
    const Pose2& dr = s.dead_reckoning_end[r];
    f.dead_reckoning_mean_m += std::hypot(dr.x - s.truth_end[r].x, dr.y - s.truth_end[r].y) / static_cast<double>(s.truth_end.size());
  }
  return f;
}

nlohmann::json to_json(const Figures& f) {
  return {{"wall_s", f.wall_s},           {"cpu_share", f.cpu_share},
          {"feature_messages", f.feature_messages}, {"odometry_messages", f.odometry_messages},
          {"updates_per_s", f.updates_per_s},   {"feature_us_mean", f.feature_us_mean},
          {"odometry_us_mean", f.odometry_us_mean}, {"lag_p50_ms", f.lag_p50_ms},
          {"lag_p99_ms", f.lag_p99_ms},         {"lag_max_s", f.lag_max_s},
          {"landmarks", f.landmarks},           {"state_dim", f.state_dim},
          {"rejected", f.rejected},             {"rejected_reasons", f.rejected_reasons},
          {"observations_used", f.observations_used},
          {"error_mean_m", f.error_mean_m},
          {"error_max_m", f.error_max_m},       {"dead_reckoning_error_mean_m", f.dead_reckoning_mean_m}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The base's fusion fed by a fleet at its real rates, on the wall clock"};
  Options o;
  bool json = false, no_baseline = false;
  app.add_option("--robots", o.robots, "robots")->check(CLI::Range(1, 100));
  app.add_option("--landmarks", o.landmarks, "poles in the field")->check(CLI::Range(1, 5000));
  app.add_option("--seconds", o.seconds, "paced seconds measured")->check(CLI::PositiveNumber);
  app.add_option("--warmup", o.warmup, "seconds of stream fed unpaced first (the map fills up)")->check(CLI::NonNegativeNumber);
  app.add_option("--scan-hz", o.scan_hz, "scans per second per robot")->check(CLI::Range(1.0, 100.0));
  app.add_option("--feature-period", o.feature_period, "robots' mapping.feature_period_s")->check(CLI::Range(0.0, 10.0));
  app.add_option("--max-lag-s", o.max_lag_s, "fail above this max lag")->check(CLI::PositiveNumber);
  app.add_option("--max-error-m", o.max_error_m, "fail above this mean final position error")->check(CLI::PositiveNumber);
  app.add_option("--min-ratio", o.min_ratio, "fail when Joseph / symmetric time per feature message is below this (0: no bound)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--seed", o.seed, "random seed of the stream");
  app.add_flag("--no-baseline", no_baseline, "skip the Joseph-form baseline run");
  app.add_flag("--json", json, "one JSON object on stdout (the table goes to stderr)");
  CLI11_PARSE(app, argc, argv);

  std::fprintf(stderr, "building the stream: %d robots, %d poles, %.0f + %.0f s at %.1f scans/s ...\n", o.robots,
               o.landmarks, o.warmup, o.seconds, o.scan_hz);
  const Stream s = make_stream(o);
  std::vector<Figures> figures;
  std::fprintf(stderr, "symmetric rank update: %.0f s warm-up unpaced, then %.0f s paced ...\n", o.warmup, o.seconds);
  figures.push_back(run("symmetric", s, ccml::CovarianceUpdate::kSymmetric));
  if (!no_baseline) {
    std::fprintf(stderr, "baseline, Joseph form: the same ...\n");
    figures.push_back(run("joseph", s, ccml::CovarianceUpdate::kJoseph));
  }

  FILE* table = json ? stderr : stdout;
  std::fprintf(table, "%-10s %8s %6s %8s %9s %9s %9s %9s %9s %6s %9s %8s\n", "update", "msgs/s", "cpu%", "upd/s",
               "feat_us", "odom_us", "lag_p50ms", "lag_p99ms", "lag_max_s", "lmarks", "err_mean", "err_max");
  for (const Figures& f : figures) {
    std::fprintf(table, "%-10s %8.0f %6.1f %8.1f %9.0f %9.1f %9.2f %9.2f %9.3f %6zu %9.3f %8.3f\n", f.name.c_str(),
                 static_cast<double>(f.feature_messages + f.odometry_messages) / f.wall_s, 100 * f.cpu_share,
                 f.updates_per_s, f.feature_us_mean, f.odometry_us_mean, f.lag_p50_ms, f.lag_p99_ms, f.lag_max_s,
                 f.landmarks, f.error_mean_m, f.error_max_m);
  }
  const Figures& sym = figures.front();
  const double seen = static_cast<double>(s.poles_seen.size());
  std::fprintf(table, "poles seen by the robots: %zu of %d (%zu in the warm-up); state dimension %zu; dead reckoning's mean error %.3f m\n",
               s.poles_seen.size(), o.landmarks, s.poles_seen_warmup.size(), sym.state_dim, sym.dead_reckoning_mean_m);
  std::vector<std::string> failures;
  if (sym.lag_max_s > o.max_lag_s) failures.push_back("max lag " + std::to_string(sym.lag_max_s) + " s > " + std::to_string(o.max_lag_s) + " s");
  if (static_cast<double>(sym.landmarks) < 0.95 * seen || static_cast<double>(sym.landmarks) > 1.02 * seen) {
    failures.push_back(std::to_string(sym.landmarks) + " landmarks for " + std::to_string(s.poles_seen.size()) + " poles seen");
  }
  if (sym.error_mean_m > o.max_error_m) {
    failures.push_back("mean position error " + std::to_string(sym.error_mean_m) + " m > " + std::to_string(o.max_error_m) + " m");
  }
  const double ratio = figures.size() == 2 && sym.feature_us_mean > 0 ? figures[1].feature_us_mean / sym.feature_us_mean : 0;
  if (o.min_ratio > 0 && ratio < o.min_ratio) {
    failures.push_back("Joseph / symmetric time per feature message " + std::to_string(ratio) + " < " + std::to_string(o.min_ratio));
  }

  nlohmann::json out = {{"bench", "fleet_fusion"}, {"robots", o.robots},           {"poles", o.landmarks},
                        {"poles_seen", s.poles_seen.size()}, {"scan_hz", o.scan_hz},  {"feature_period_s", o.feature_period},
                        {"warmup_s", o.warmup},              {"seconds", o.seconds},  {"max_lag_s", o.max_lag_s},
                        {"poles_seen_warmup", s.poles_seen_warmup.size()}, {"max_error_m", o.max_error_m}, {"min_ratio", o.min_ratio}};
  for (const Figures& f : figures) out[f.name] = to_json(f);
  if (ratio > 0) {
    out["joseph_over_symmetric_feature_us"] = ratio;
    std::fprintf(table, "Joseph / symmetric time per feature message: %.2f\n", ratio);
  }
  out["pass"] = failures.empty();
  out["failures"] = failures;
  if (json) std::printf("%s\n", out.dump(2).c_str());
  for (const std::string& f : failures) std::fprintf(stderr, "FAIL: %s\n", f.c_str());
  return failures.empty() ? 0 : 1;
}
