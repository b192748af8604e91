// Round trips between Cairn's messages and the IDL structs (common/dds/convert.hpp), and
// the clamping of hostile counts on the way in.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>

#include "common/dds/convert.hpp"

namespace cairn {
namespace {

/// Stores an out-of-range value into an IDL enum field, as a hostile sample would carry.
template <typename E>
void set_raw_enum(E* field, int value) {
  static_assert(sizeof(E) == sizeof(int));
  std::memcpy(field, &value, sizeof value);
}

TEST(Convert, OdometryRoundTrip) {
  msg::OdometryIncrement a;
  a.robot_id = 7;
  a.seq = 42;
  a.t0 = 1'000'000'123;
  a.t1 = 1'013'000'456;
  a.delta = {0.1, -0.02, 0.03};
  for (std::size_t i = 0; i < 9; ++i) a.delta_cov[i] = 0.001 * static_cast<double>(i + 1);
  a.local_pose = {3.0, 4.0, -1.0};
  a.boot_epoch = 0xC0FFEE01u;
  cairn_OdometryIncrement d{};
  dds::to_dds(a, &d);
  EXPECT_EQ(d.seq, 42u);
  EXPECT_DOUBLE_EQ(d.delta_cov[5], 0.006);
  msg::OdometryIncrement b;
  EXPECT_TRUE(dds::from_dds(d, &b));
  EXPECT_EQ(b.robot_id, 7);
  EXPECT_EQ(b.t0, a.t0);
  EXPECT_EQ(b.t1, a.t1);
  EXPECT_EQ(b.delta_cov, a.delta_cov);
  EXPECT_DOUBLE_EQ(b.local_pose.theta, -1.0);
  EXPECT_EQ(d.boot_epoch, 0xC0FFEE01u);
  EXPECT_EQ(b.boot_epoch, a.boot_epoch);
  EXPECT_EQ(msg::OdometryIncrement{}.boot_epoch, 0u);  // default: not set
}

TEST(Convert, LaserScanRoundTripAndClamp) {
  auto a = std::make_unique<msg::LaserScan>();
  a->robot_id = 2;
  a->seq = 9;
  a->stamp = 77;
  a->angle_min = -1.5f;
  a->angle_increment = 0.0087f;
  a->beam_period_s = 1.85e-5f;
  a->n_beams = 361;
  for (std::size_t i = 0; i < 361; ++i) {
    a->ranges_mm[i] = static_cast<std::uint16_t>(1000 + i);
    a->reflectivity[i] = static_cast<std::uint8_t>(i % 3);
  }
  a->pose = {1, 2, 3};
  a->sensor_offset = {0.2, 0, 0};
  auto d = std::make_unique<cairn_LaserScan>();
  std::memset(d.get(), 0, sizeof *d);
  dds::to_dds(*a, d.get());
  auto b = std::make_unique<msg::LaserScan>();
  EXPECT_TRUE(dds::from_dds(*d, b.get()));
  EXPECT_EQ(*a, *b);  // member by member (padding bytes are unspecified)
  d->n_beams = 60000;  // hostile
  EXPECT_FALSE(dds::from_dds(*d, b.get()));
  EXPECT_EQ(b->n_beams, msg::kMaxBeams);
}

TEST(Convert, FeaturesRoundTripAndClamp) {
  msg::FeatureObservations a;
  a.robot_id = 3;
  a.seq = 5;
  a.stamp = 99;
  a.local_pose = {1, 1, 0.5};
  a.odom_seq = 4;
  a.boot_epoch = 77;
  a.n_features = 2;
  a.features[0] = {msg::FeatureKind::kLandmark, -1, 4.0, 0.3, {0.0009, 0, 0, 1e-4}};
  a.features[1] = {msg::FeatureKind::kRobot, 2, 6.0, -0.3, {0.001, 1e-6, 1e-6, 2e-4}};
  cairn_FeatureObservations d{};
  dds::to_dds(a, &d);
  EXPECT_EQ(d.features[1].kind, cairn_FEATURE_ROBOT);
  EXPECT_EQ(d.features[1].marker_id, 2);
  EXPECT_EQ(d.boot_epoch, 77u);
  msg::FeatureObservations b;
  EXPECT_TRUE(dds::from_dds(d, &b));
  EXPECT_EQ(a, b);  // member by member (padding bytes are unspecified)
  d.n_features = 200;
  EXPECT_FALSE(dds::from_dds(d, &b));
  EXPECT_EQ(b.n_features, msg::kMaxFeatures);
  d.n_features = 1;
  set_raw_enum(&d.features[0].kind, 9);
  EXPECT_FALSE(dds::from_dds(d, &b));
}

TEST(Convert, CorrectionAndTaskRoundTrip) {
  msg::PoseCorrection c;
  c.robot_id = 4;
  c.seq = 8;
  c.stamp = 123;
  c.local_to_global = {1, 2, 0.1};
  c.global_pose = {3, 4, 0.2};
  c.global_cov[0] = 0.01;
  cairn_PoseCorrection dc{};
  dds::to_dds(c, &dc);
  msg::PoseCorrection c2;
  EXPECT_TRUE(dds::from_dds(dc, &c2));
  EXPECT_EQ(c, c2);  // member by member (padding bytes are unspecified)

  msg::TaskAssignment t;
  t.robot_id = 4;
  t.seq = 1;
  t.task_id = 17;
  t.issued = 5;
  t.kind = msg::TaskKind::kGoto;
  t.target_x = 9;
  t.target_y = -9;
  t.n_path = 3;
  for (std::size_t i = 0; i < 6; ++i) t.path_xy[i] = static_cast<double>(i);
  cairn_TaskAssignment dt{};
  dds::to_dds(t, &dt);
  msg::TaskAssignment t2;
  EXPECT_TRUE(dds::from_dds(dt, &t2));
  EXPECT_EQ(t, t2);  // member by member (padding bytes are unspecified)
  dt.n_path = 1000;
  set_raw_enum(&dt.kind, 42);
  EXPECT_FALSE(dds::from_dds(dt, &t2));
  EXPECT_EQ(t2.n_path, msg::kMaxPath);
  EXPECT_EQ(t2.kind, msg::TaskKind::kStop);
}

TEST(Convert, BidRoundTripsAndAnOversizedCountIsClamped) {
  msg::Bid b;
  b.robot_id = 3;
  b.seq = 17;
  b.map_version = 9;
  b.n_items = 2;
  b.items[0] = {1.5, -2.0, 120, 3.25, 0, -4, 3, 0};
  b.items[1] = {-7.0, 8.0, 40, 11.0, -9, 6, -5, 10};
  b.n_unreachable = 2;
  b.unreachable_dropped = 5;
  b.unreachable[0] = {4.125, -1.5, 3.9, -1.8, 4.35, -1.2, 12, msg::UnreachableKind::kTooNarrow};
  b.unreachable[1] = {-20.0, 30.5, -21.0, 30.0, -19.0, 31.0, 7, msg::UnreachableKind::kDisconnected};
  auto d = std::make_unique<cairn_Bid>();
  dds::to_dds(b, d.get());
  msg::Bid back;
  ASSERT_TRUE(dds::from_dds(*d, &back));
  EXPECT_EQ(back.robot_id, 3);
  EXPECT_EQ(back.seq, 17u);
  EXPECT_EQ(back.map_version, 9u);
  ASSERT_EQ(back.n_items, 2);
  EXPECT_EQ(back.items[1].x, -7.0);
  EXPECT_EQ(back.items[1].cost, 11.0);
  EXPECT_EQ(back.items[1].igr_max_y, 10.0);
  EXPECT_EQ(back.items[0].igr_min_y, -4.0);
  ASSERT_EQ(back.n_unreachable, 2);
  EXPECT_EQ(back.unreachable_dropped, 5u);
  EXPECT_EQ(back.unreachable[0], b.unreachable[0]);
  EXPECT_EQ(back.unreachable[1], b.unreachable[1]);
  EXPECT_EQ(back, b);  // every field, the unused slots included (zero on both sides)
  d->n_unreachable = 60000;  // a hostile cluster count
  EXPECT_FALSE(dds::from_dds(*d, &back));
  EXPECT_EQ(back.n_unreachable, msg::kMaxUnreachable);
  d->n_unreachable = 1;
  d->n_items = 60000;  // a hostile count
  EXPECT_FALSE(dds::from_dds(*d, &back));
  EXPECT_EQ(back.n_items, msg::kMaxBids);
}

TEST(Convert, SafetyStopRoundTripsAndAnUnterminatedNameIsCut) {
  msg::SafetyStop s;
  s.robot_id = 0;  // every robot
  s.seq = 4;
  s.issued = 987654321;
  const char who[] = "web view";
  std::memcpy(s.issued_by.data(), who, sizeof who);
  cairn_SafetyStop d{};
  dds::to_dds(s, &d);
  EXPECT_EQ(d.robot_id, 0);
  EXPECT_STREQ(d.issued_by, who);
  msg::SafetyStop s2;
  s2.robot_id = 9;
  EXPECT_TRUE(dds::from_dds(d, &s2));
  EXPECT_EQ(s2.robot_id, 0);
  EXPECT_EQ(s2.seq, 4u);
  EXPECT_EQ(s2.issued, 987654321);
  EXPECT_STREQ(s2.issued_by.data(), who);
  std::memset(d.issued_by, 'x', sizeof d.issued_by);
  EXPECT_TRUE(dds::from_dds(d, &s2));
  EXPECT_EQ(std::strlen(s2.issued_by.data()), s2.issued_by.size() - 1);
}

TEST(Convert, SafetyResetRoundTripsAndAnUnterminatedNameIsCut) {
  msg::SafetyReset r;
  r.robot_id = 3;
  r.seq = 9;
  r.issued = 123456789;
  r.remote_stops_seen = 4;
  const char who[] = "operator at the base";
  std::memcpy(r.issued_by.data(), who, sizeof who);
  cairn_SafetyReset d{};
  dds::to_dds(r, &d);
  EXPECT_STREQ(d.issued_by, who);
  msg::SafetyReset r2;
  EXPECT_TRUE(dds::from_dds(d, &r2));
  EXPECT_EQ(r2.robot_id, 3);
  EXPECT_EQ(r2.seq, 9u);
  EXPECT_EQ(r2.issued, 123456789);
  EXPECT_EQ(r2.remote_stops_seen, 4u);
  EXPECT_STREQ(r2.issued_by.data(), who);
  std::memset(d.issued_by, 'x', sizeof d.issued_by);  // no terminator from the wire
  EXPECT_TRUE(dds::from_dds(d, &r2));
  EXPECT_EQ(std::strlen(r2.issued_by.data()), r2.issued_by.size() - 1);
}

TEST(Convert, LandmarkPages) {
  std::vector<msg::Landmark> all(300);
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = {static_cast<std::uint32_t>(i), static_cast<double>(i), -static_cast<double>(i), {1, 0, 0, 1}};
  auto d = std::make_unique<cairn_FeatureMap>();
  std::size_t seen = 0;
  for (std::size_t first = 0; first < all.size(); first += msg::kMaxLandmarks) {
    dds::to_dds_page(all.data(), all.size(), first, 1, 2, d.get());
    for (std::size_t i = 0; i < d->n_landmarks; ++i) EXPECT_EQ(d->landmarks[i].id, first + i);
    EXPECT_EQ(d->page, first / msg::kMaxLandmarks);
    EXPECT_EQ(d->n_pages, 3u);
    EXPECT_EQ(d->total, 300u);
    seen += d->n_landmarks;
  }
  EXPECT_EQ(seen, all.size());
}

}  // namespace
}  // namespace cairn
