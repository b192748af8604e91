#include "tools/fuzz_base/sample_mutator.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace cairn::fuzz {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

void terminate(char* s, std::size_t capacity, std::size_t at) { s[std::min(at, capacity - 1)] = '\0'; }

}  // namespace

const char* topic_name(Topic t) {
  switch (t) {
    case Topic::kOdometry: return "odometry";
    case Topic::kFeatures: return "features";
    case Topic::kScan: return "scan";
    case Topic::kStatus: return "status";
    case Topic::kBid: return "bid";
    case Topic::kVisit: return "visit";
    case Topic::kCount: break;
  }
  return "?";
}

const char* mutation_name(Mutation m) {
  switch (m) {
    case Mutation::kPlausible: return "plausible";
    case Mutation::kRandomBytes: return "random_bytes";
    case Mutation::kNonFinite: return "non_finite";
    case Mutation::kHuge: return "huge";
    case Mutation::kBadCovariance: return "bad_covariance";
    case Mutation::kCountOverflow: return "count_overflow";
    case Mutation::kSeqExtreme: return "seq_extreme";
    case Mutation::kEpochChange: return "epoch_change";
    case Mutation::kTimeWarp: return "time_warp";
    case Mutation::kBadMarker: return "bad_marker";
    case Mutation::kCount: break;
  }
  return "?";
}

bool SampleMutator::refused_as_a_whole(Mutation m) {
  return m == Mutation::kNonFinite || m == Mutation::kHuge || m == Mutation::kBadCovariance || m == Mutation::kCountOverflow;
}

SampleMutator::SampleMutator(MutatorConfig cfg) : cfg_(std::move(cfg)), rng_(cfg_.seed), fakes_(cfg_.fake_robots) {
  if (cfg_.fake_robots == 0 || cfg_.first_fake_id == 0 || cfg_.first_fake_id + cfg_.fake_robots > 65536) {
    throw std::invalid_argument("fuzz: the fake robots' ids must lie in 1..65535");
  }
  for (std::uint16_t id : cfg_.fleet) {
    if (id >= cfg_.first_fake_id && id - cfg_.first_fake_id < cfg_.fake_robots) {
      throw std::invalid_argument("fuzz: robot " + std::to_string(id) + " is both in the fleet and a fake robot");
    }
  }
  for (std::size_t i = 0; i < fakes_.size(); ++i) {
    fakes_[i].x = static_cast<double>(i);
    fakes_[i].epoch = 1 + static_cast<std::uint32_t>(i);
  }
}

bool SampleMutator::real(std::uint16_t id) const { return std::find(cfg_.fleet.begin(), cfg_.fleet.end(), id) != cfg_.fleet.end(); }

std::uint16_t SampleMutator::pick_fake() {
  std::uniform_int_distribution<std::uint16_t> d(0, static_cast<std::uint16_t>(cfg_.fake_robots - 1));
  return static_cast<std::uint16_t>(cfg_.first_fake_id + d(rng_));
}

std::uint16_t SampleMutator::pick_real() {
  std::uniform_int_distribution<std::size_t> d(0, cfg_.fleet.size() - 1);
  return cfg_.fleet[d(rng_)];
}

void SampleMutator::sweep(std::uint16_t* robot_id) {
  std::bernoulli_distribution half(0.5);
  const bool fake = *robot_id >= cfg_.first_fake_id && *robot_id - cfg_.first_fake_id < cfg_.fake_robots;
  // Only a fake robot's id is replaced: an id already drawn from the sweep is kept, so none is skipped.
  if (!cfg_.sweep_ids || !fake || !half(rng_)) return;
  *robot_id = random_non_real_id();
}

std::uint16_t SampleMutator::random_non_real_id() {
  if (cfg_.sweep_ids) {
    while (real(sweep_next_)) ++sweep_next_;
    return sweep_next_++;  // wraps at 65536
  }
  std::uniform_int_distribution<std::uint32_t> d(0, 65535);
  for (;;) {
    const auto id = static_cast<std::uint16_t>(d(rng_));
    if (!real(id)) return id;
  }
}

Mutation SampleMutator::pick(bool real_robot, bool has_counts, bool has_cov) {
  std::vector<Mutation> menu;
  if (real_robot) {
    menu = {Mutation::kNonFinite, Mutation::kHuge};
    if (has_cov) menu.push_back(Mutation::kBadCovariance);
    if (has_counts) menu.push_back(Mutation::kCountOverflow);
  } else {
    menu = {Mutation::kPlausible, Mutation::kPlausible, Mutation::kPlausible, Mutation::kRandomBytes, Mutation::kNonFinite,
            Mutation::kHuge, Mutation::kSeqExtreme, Mutation::kEpochChange, Mutation::kTimeWarp};
    if (has_cov) menu.push_back(Mutation::kBadCovariance);
    if (has_counts) menu.push_back(Mutation::kCountOverflow);
  }
  std::uniform_int_distribution<std::size_t> d(0, menu.size() - 1);
  return menu[d(rng_)];
}

double SampleMutator::weird_value() {
  const double v[] = {kNan, kInf, -kInf, -kNan};
  std::uniform_int_distribution<int> d(0, 3);
  return v[d(rng_)];
}

double SampleMutator::huge_value() {
  const double v[] = {1e12, -1e12, 1e300, -1e300, std::numeric_limits<double>::max()};
  std::uniform_int_distribution<int> d(0, 4);
  return v[d(rng_)];
}

template <typename T>
void SampleMutator::random_bytes(T* s) {
  auto* p = reinterpret_cast<unsigned char*>(s);
  for (std::size_t i = 0; i < sizeof(T); ++i) p[i] = static_cast<unsigned char>(rng_());
}

template <typename T>
bool SampleMutator::randomised(Mutation m, T* s) {
  if (m != Mutation::kRandomBytes) return false;
  random_bytes(s);
  s->robot_id = random_non_real_id();
  return true;
}

void SampleMutator::plausible_odometry(std::uint16_t id, cairn_OdometryIncrement* s) {
  Fake& f = fakes_[id - cfg_.first_fake_id];
  std::normal_distribution<double> g(0.0, 1.0);
  *s = {};
  s->robot_id = id;
  s->seq = ++f.odom_seq;
  s->t0_ns = f.t_ns;
  f.t_ns += 100'000'000;
  s->t1_ns = f.t_ns;
  s->delta = {0.04 + 0.01 * g(rng_), 0.005 * g(rng_), 0.02 * g(rng_)};
  s->delta_cov[0] = s->delta_cov[4] = 1e-4;
  s->delta_cov[8] = 2.5e-5;
  f.x += s->delta.x * std::cos(f.theta);
  f.y += s->delta.x * std::sin(f.theta);
  f.theta += s->delta.theta;
  s->local_pose = {f.x, f.y, f.theta};
  s->boot_epoch = f.epoch;
}

void SampleMutator::plausible_features(std::uint16_t id, cairn_FeatureObservations* s) {
  Fake& f = fakes_[id - cfg_.first_fake_id];
  std::uniform_real_distribution<double> range(0.5, 7.0), bearing(-std::numbers::pi, std::numbers::pi);
  std::uniform_int_distribution<int> n(0, 8);
  *s = {};
  s->robot_id = id;
  s->seq = ++f.feat_seq;
  s->stamp_ns = f.t_ns;
  s->local_pose = {f.x, f.y, f.theta};
  s->odom_seq = f.odom_seq;
  s->boot_epoch = f.epoch;
  s->n_features = static_cast<std::uint8_t>(n(rng_));
  for (std::uint8_t i = 0; i < s->n_features; ++i) {
    cairn_Feature& ft = s->features[i];
    ft.kind = cairn_FEATURE_LANDMARK;
    ft.marker_id = -1;
    ft.range = range(rng_);
    ft.bearing = bearing(rng_);
    ft.cov[0] = 0.0025;
    ft.cov[3] = 7e-4;
  }
}

Mutation SampleMutator::odometry(cairn_OdometryIncrement* s) {
  std::bernoulli_distribution real_robot(cfg_.fleet.empty() ? 0.0 : 0.2);
  const bool r = real_robot(rng_);
  const Mutation m = pick(r, false, true);
  if (randomised(m, s)) return m;
  const std::uint16_t fake = pick_fake();
  plausible_odometry(fake, s);
  if (r) s->robot_id = pick_real();
  std::uniform_int_distribution<int> field(0, 8);
  switch (m) {
    case Mutation::kNonFinite: {
      double* fields[] = {&s->delta.x, &s->delta.y, &s->delta.theta, &s->local_pose.x, &s->local_pose.y, &s->local_pose.theta,
                          &s->delta_cov[0], &s->delta_cov[4], &s->delta_cov[8]};
      *fields[field(rng_)] = weird_value();
      break;
    }
    case Mutation::kHuge: {
      // For a real robot only fields the base bounds; a fake one also gets huge headings.
      double* fields[] = {&s->delta.x, &s->delta.y, &s->delta.theta, &s->local_pose.x, &s->local_pose.y,
                          &s->delta_cov[0], &s->delta_cov[4], &s->delta_cov[8], &s->local_pose.theta};
      std::uniform_int_distribution<int> pickf(0, r ? 7 : 8);
      *fields[pickf(rng_)] = std::abs(huge_value());
      break;
    }
    case Mutation::kBadCovariance:
      if (field(rng_) % 2 == 0) {
        s->delta_cov[4] = -1e-3;
      } else {
        s->delta_cov[1] = 1e-3;
        s->delta_cov[3] = -1e-3;
      }
      break;
    case Mutation::kSeqExtreme: {
      const std::uint32_t v[] = {0, std::numeric_limits<std::uint32_t>::max(), s->seq + 1'000'000, s->seq + 10'001};
      s->seq = v[field(rng_) % 4];
      break;
    }
    case Mutation::kEpochChange:
      fakes_[fake - cfg_.first_fake_id].epoch = static_cast<std::uint32_t>(rng_());
      s->boot_epoch = fakes_[fake - cfg_.first_fake_id].epoch;
      break;
    case Mutation::kTimeWarp:
      s->t0_ns = std::numeric_limits<std::int64_t>::max();
      s->t1_ns = field(rng_) % 2 ? std::numeric_limits<std::int64_t>::min() : -1;
      break;
    default: break;
  }
  return m;
}

Mutation SampleMutator::features(cairn_FeatureObservations* s) {
  std::bernoulli_distribution real_robot(cfg_.fleet.empty() ? 0.0 : 0.2);
  const bool r = real_robot(rng_);
  Mutation m = pick(r, true, true);
  if (!r && m == Mutation::kPlausible) {
    std::bernoulli_distribution marker(0.15);
    if (marker(rng_)) m = Mutation::kBadMarker;
  }
  if (randomised(m, s)) {
    for (auto& f : s->features) f.kind = rng_() % 2 ? cairn_FEATURE_ROBOT : cairn_FEATURE_LANDMARK;
    return m;
  }
  const std::uint16_t fake = pick_fake();
  plausible_features(fake, s);
  if (r) s->robot_id = pick_real();
  if (s->n_features == 0 && m != Mutation::kPlausible && m != Mutation::kCountOverflow) s->n_features = 1;
  s->features[0].kind = cairn_FEATURE_LANDMARK;
  if (s->features[0].range == 0) {
    s->features[0].range = 2.0;
    s->features[0].cov[0] = 0.0025;
    s->features[0].cov[3] = 7e-4;
  }
  std::uniform_int_distribution<int> field(0, 5);
  cairn_Feature& ft = s->features[0];
  switch (m) {
    case Mutation::kNonFinite: {
      double* fields[] = {&ft.range, &ft.bearing, &ft.cov[0], &ft.cov[3], &s->local_pose.x, &s->local_pose.y};
      *fields[field(rng_)] = weird_value();
      break;
    }
    case Mutation::kHuge: {
      double* fields[] = {&ft.range, &ft.cov[0], &ft.cov[3], &s->local_pose.x, &s->local_pose.y, &s->local_pose.theta};
      std::uniform_int_distribution<int> pickf(0, r ? 4 : 5);
      *fields[pickf(rng_)] = std::abs(huge_value());
      break;
    }
    case Mutation::kBadCovariance:
      if (field(rng_) % 2 == 0) {
        ft.cov[0] = -0.01;
      } else {
        ft.cov[1] = 0.01;
        ft.cov[2] = -0.01;
      }
      break;
    case Mutation::kCountOverflow: {
      std::uniform_int_distribution<int> n(cairn_MAX_FEATURES + 1, 255);
      s->n_features = static_cast<std::uint8_t>(n(rng_));
      break;
    }
    case Mutation::kSeqExtreme: {
      const std::uint32_t v[] = {0, std::numeric_limits<std::uint32_t>::max(), s->seq + 1'000'000};
      s->seq = v[field(rng_) % 3];
      s->odom_seq = field(rng_) % 2 ? std::numeric_limits<std::uint32_t>::max() : s->odom_seq + 50'000;
      break;
    }
    case Mutation::kEpochChange: s->boot_epoch = static_cast<std::uint32_t>(rng_()); break;
    case Mutation::kTimeWarp: s->stamp_ns = field(rng_) % 2 ? std::numeric_limits<std::int64_t>::min() : -5; break;
    case Mutation::kBadMarker: {
      ft.kind = cairn_FEATURE_ROBOT;
      const std::int32_t own = s->robot_id;
      const std::int32_t shadow = 65536 + (cfg_.fleet.empty() ? 1 : cfg_.fleet.front());  // the old crash
      const std::int32_t v[] = {0, own, shadow, -5, std::numeric_limits<std::int32_t>::max(), 70000};
      ft.marker_id = v[field(rng_)];
      break;
    }
    default: break;
  }
  return m;
}

Mutation SampleMutator::scan(cairn_LaserScan* s) {
  const Mutation m = pick(false, true, true);
  if (randomised(m, s)) return m;
  const std::uint16_t id = pick_fake();
  const Fake& f = fakes_[id - cfg_.first_fake_id];
  *s = {};
  s->robot_id = id;
  s->seq = ++fakes_[id - cfg_.first_fake_id].scan_seq;
  s->stamp_ns = f.t_ns;
  s->angle_min = static_cast<float>(-std::numbers::pi / 2);
  s->angle_increment = static_cast<float>(std::numbers::pi / 360);
  s->beam_period_s = 1.0f / 75 / 1440;
  s->n_beams = 361;
  std::uniform_int_distribution<int> mm(0, 8000);
  for (int i = 0; i < 361; ++i) s->ranges_mm[i] = static_cast<std::uint16_t>(mm(rng_));
  s->pose = {f.x, f.y, f.theta};
  s->pose_cov[0] = s->pose_cov[4] = 1e-4;
  s->pose_cov[8] = 1e-5;
  std::uniform_int_distribution<int> field(0, 4);
  switch (m) {
    case Mutation::kNonFinite: {
      const double w = weird_value();
      switch (field(rng_)) {
        case 0: s->angle_min = static_cast<float>(w); break;
        case 1: s->angle_increment = static_cast<float>(w); break;
        case 2: s->pose.x = w; break;
        case 3: s->pose.theta = w; break;
        default: s->sensor_offset.y = w; break;
      }
      break;
    }
    case Mutation::kHuge:
      switch (field(rng_)) {
        case 0: s->angle_increment = 1e30f; break;
        case 1: s->pose.x = huge_value(); break;
        case 2: s->pose.theta = huge_value(); break;
        case 3: s->beam_period_s = -1e30f; break;
        default: s->sensor_offset.x = huge_value(); break;
      }
      break;
    case Mutation::kBadCovariance: s->pose_cov[0] = -1; break;
    case Mutation::kCountOverflow: {
      std::uniform_int_distribution<int> n(cairn_MAX_BEAMS + 1, 65535);
      s->n_beams = static_cast<std::uint16_t>(n(rng_));
      break;
    }
    case Mutation::kSeqExtreme: s->seq = field(rng_) % 2 ? 0 : std::numeric_limits<std::uint32_t>::max(); break;
    case Mutation::kEpochChange: s->angle_increment = 0; break;  // no epoch in a scan: a degenerate fan instead
    case Mutation::kTimeWarp: s->stamp_ns = field(rng_) % 2 ? std::numeric_limits<std::int64_t>::max() : -1; break;
    default: break;
  }
  return m;
}

Mutation SampleMutator::status(cairn_RobotStatus* s) {
  const Mutation m = pick(false, true, false);
  if (randomised(m, s)) {
    s->mode = static_cast<cairn_RobotMode>(rng_() % 5);
    std::uniform_int_distribution<std::size_t> at(0, 200);
    terminate(s->name, sizeof s->name, at(rng_));
    terminate(s->stop_text, sizeof s->stop_text, at(rng_));
    for (auto& d : s->devices) {
      terminate(d.name, sizeof d.name, at(rng_));
      terminate(d.reason, sizeof d.reason, at(rng_));
    }
    return m;
  }
  // Fake robots and, as a robot gone wild would, any id outside the fleet.
  std::bernoulli_distribution any(0.5);
  const std::uint16_t id = any(rng_) ? random_non_real_id() : pick_fake();
  *s = {};
  s->robot_id = id;
  s->seq = id >= cfg_.first_fake_id && id < cfg_.first_fake_id + cfg_.fake_robots ? ++fakes_[id - cfg_.first_fake_id].status_seq : 1;
  std::snprintf(s->name, sizeof s->name, "fuzz-%u", static_cast<unsigned>(id));
  s->mode = cairn_MODE_RUNNING;
  s->n_devices = 1;
  std::snprintf(s->devices[0].name, sizeof s->devices[0].name, "lms");
  std::uniform_int_distribution<int> field(0, 3);
  switch (m) {
    case Mutation::kNonFinite: s->battery_voltage = static_cast<float>(weird_value()); break;
    case Mutation::kHuge: s->local_pose.x = huge_value(); break;
    case Mutation::kCountOverflow: s->n_devices = static_cast<std::uint8_t>(cairn_MAX_DEVICES + 1 + field(rng_) * 50); break;
    case Mutation::kSeqExtreme: s->seq = std::numeric_limits<std::uint32_t>::max(); break;
    case Mutation::kEpochChange: s->seq = 0; break;
    case Mutation::kTimeWarp: s->stamp_ns = std::numeric_limits<std::int64_t>::min(); break;
    default: s->stop_reason = static_cast<std::uint8_t>(rng_()); break;
  }
  return m;
}

Mutation SampleMutator::bid(cairn_Bid* s) {
  const Mutation m = pick(false, true, false);
  if (randomised(m, s)) return m;
  const std::uint16_t id = pick_fake();
  const Fake& f = fakes_[id - cfg_.first_fake_id];
  *s = {};
  s->robot_id = id;
  s->seq = ++fakes_[id - cfg_.first_fake_id].bid_seq;
  s->map_version = s->seq;
  std::uniform_int_distribution<int> n(0, 12);
  std::uniform_real_distribution<double> off(-5, 5), gain(1, 500);
  s->n_items = static_cast<std::uint16_t>(n(rng_));
  for (std::uint16_t i = 0; i < s->n_items; ++i) {
    cairn_BidItem& b = s->items[i];
    b.x = f.x + off(rng_);
    b.y = f.y + off(rng_);
    b.gain = gain(rng_);
    b.cost = std::abs(off(rng_));
    b.igr_min_x = b.x - 1;
    b.igr_min_y = b.y - 1;
    b.igr_max_x = b.x + 1;
    b.igr_max_y = b.y + 1;
  }
  if (s->n_items == 0) s->n_items = 1;
  // Unreachable frontier clusters (docs/explore.md): plausible ones, one of which the
  // mutations below may spoil.
  s->n_unreachable = static_cast<std::uint16_t>(n(rng_) % 3);
  for (std::uint16_t i = 0; i < s->n_unreachable; ++i) {
    cairn_UnreachableCluster& u = s->unreachable[i];
    u.x = f.x + off(rng_);
    u.y = f.y + off(rng_);
    u.min_x = u.x - 0.3;
    u.min_y = u.y - 0.3;
    u.max_x = u.x + 0.3;
    u.max_y = u.y + 0.3;
    u.cells = 1 + static_cast<std::uint32_t>(n(rng_));
    u.kind = static_cast<std::uint8_t>(i % 2);
  }
  std::uniform_int_distribution<int> field(0, 3);
  cairn_BidItem& b = s->items[0];
  cairn_UnreachableCluster& u = s->unreachable[0];
  switch (m) {
    case Mutation::kNonFinite: {
      if (s->n_unreachable > 0 && field(rng_) == 0) {  // a cluster's field instead of the item's
        double* fields[] = {&u.x, &u.y, &u.min_x, &u.max_y};
        *fields[field(rng_)] = weird_value();
        break;
      }
      double* fields[] = {&b.x, &b.y, &b.gain, &b.cost};
      *fields[field(rng_)] = weird_value();
      break;
    }
    case Mutation::kHuge: {
      double* fields[] = {&b.x, &b.gain, &b.cost, &b.igr_max_x};
      *fields[field(rng_)] = huge_value();
      break;
    }
    case Mutation::kCountOverflow: {
      std::uniform_int_distribution<int> c(cairn_MAX_BIDS + 1, 65535);
      if (field(rng_) == 0) {
        s->n_unreachable = static_cast<std::uint16_t>(c(rng_));
      } else {
        s->n_items = static_cast<std::uint16_t>(c(rng_));
      }
      break;
    }
    case Mutation::kSeqExtreme: s->seq = field(rng_) % 2 ? 0 : std::numeric_limits<std::uint32_t>::max(); break;
    case Mutation::kEpochChange: s->map_version = 0; break;
    case Mutation::kTimeWarp:
      if (s->n_unreachable > 0 && field(rng_) == 0) {
        u.kind = 200;  // no such kind
      } else {
        b.gain = -b.gain;
      }
      break;
    default: break;
  }
  return m;
}

Mutation SampleMutator::visit(cairn_VisitRequest* s) {
  const Mutation m = pick(false, false, false);
  if (randomised(m, s)) {
    std::uniform_int_distribution<std::size_t> at(0, 200);
    terminate(s->issued_by, sizeof s->issued_by, at(rng_));
    return m;
  }
  const std::uint16_t id = pick_fake();
  const Fake& f = fakes_[id - cfg_.first_fake_id];
  *s = {};
  s->robot_id = id;
  s->seq = ++visit_seq_;
  s->issued_ns = f.t_ns;
  std::uniform_real_distribution<double> off(-5, 5);
  s->x = f.x + off(rng_);
  s->y = f.y + off(rng_);
  std::snprintf(s->issued_by, sizeof s->issued_by, "cairn-fuzz-base");
  switch (m) {
    case Mutation::kNonFinite: (rng_() % 2 ? s->x : s->y) = weird_value(); break;
    case Mutation::kHuge: (rng_() % 2 ? s->x : s->y) = huge_value(); break;
    case Mutation::kSeqExtreme: s->seq = rng_() % 2 ? 0 : std::numeric_limits<std::uint32_t>::max(); break;
    case Mutation::kTimeWarp: s->issued_ns = std::numeric_limits<std::int64_t>::min(); break;
    default: break;  // kEpochChange: a request has no epoch
  }
  return m;
}

}  // namespace cairn::fuzz
