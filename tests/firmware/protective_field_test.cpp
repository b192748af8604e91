// The laser protective field, pure: the speed it allows for the requested arc from the
// last scan's returns, the robot's motion since the scan, turning in place and reverse.
#include "firmware/executive/protective_field.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace cairn::firmware {
namespace {

constexpr double kMaxV = 0.8, kAcc = 0.8;
constexpr std::size_t kBeams = 361;
constexpr double kIncrement = std::numbers::pi / 360;  // 0.5°
constexpr double kAngleMin = -std::numbers::pi / 2;

// A 180° scan from a laser at the robot's centre, returns only on the given points (nearest
// beam), none elsewhere.
std::vector<std::uint16_t> scan_of(const std::vector<Vec2>& points) {
  std::vector<std::uint16_t> r(kBeams, 0);
  for (const Vec2& p : points) {
    const double a = std::atan2(p.y(), p.x());
    const long i = std::lround((a - kAngleMin) / kIncrement);
    if (i < 0 || i >= static_cast<long>(kBeams)) continue;
    r[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(std::lround(p.norm() * 1000));
  }
  return r;
}

// A wall across the path at x = d (a return every 0.5°).
std::vector<std::uint16_t> wall_at(double d) {
  std::vector<std::uint16_t> r(kBeams, 0);
  for (std::size_t i = 0; i < kBeams; ++i) {
    const double c = std::cos(kAngleMin + kIncrement * static_cast<double>(i));
    if (c > 0.05) r[i] = static_cast<std::uint16_t>(std::lround(std::min(d / c, 30.0) * 1000));
  }
  return r;
}

ProtectiveField field_seeing(const std::vector<std::uint16_t>& ranges, ProtectiveFieldConfig cfg = {}) {
  ProtectiveField f(cfg, kMaxV, kAcc);
  f.on_scan(ranges.data(), ranges.size(), kAngleMin, kIncrement, Pose2{});
  return f;
}

TEST(ProtectiveField, SpeedForIsTheInverseOfTheStoppingDistance) {
  const ProtectiveField f(ProtectiveFieldConfig{}, kMaxV, kAcc);
  for (double v : {0.05, 0.2, 0.5, 0.8}) EXPECT_NEAR(f.speed_for(f.stopping_distance(v)), v, 1e-9);
  // 0.8 m/s: 0.08 m reacting, 0.4 m braking, 0.05 m margin.
  EXPECT_NEAR(f.stopping_distance(0.8), 0.53, 1e-12);
  EXPECT_EQ(f.speed_for(0.05), 0.0);
}

TEST(ProtectiveField, AWallAheadAllowsTheSpeedThatStopsBeforeIt) {
  // Beyond the stopping distance at max_v (0.53 m from the body's front): no limit.
  EXPECT_FALSE(field_seeing(wall_at(0.9)).limit(0.8, 0.0, Pose2{}).limited);
  const ProtectiveField f = field_seeing(wall_at(0.8));
  const FieldLimit l = f.limit(0.8, 0.0, Pose2{});
  ASSERT_TRUE(l.limited);
  // The body's front, widened by the side margin (0.32 m), is 0.48 m from the wall; the
  // nearest return is straight ahead.
  EXPECT_NEAR(l.free_m, 0.48, 0.005);
  EXPECT_NEAR(l.nearest.y(), 0.0, 0.01);
  EXPECT_NEAR(l.forward_max_v, f.speed_for(0.48), 0.01);
  EXPECT_LT(l.forward_max_v, 0.8);
  EXPECT_GT(l.forward_max_v, 0.7);
  // Closer: slower; at the margin: blocked.
  EXPECT_LT(field_seeing(wall_at(0.5)).limit(0.8, 0, Pose2{}).forward_max_v, 0.4);
  EXPECT_EQ(field_seeing(wall_at(0.34)).limit(0.8, 0, Pose2{}).forward_max_v, 0.0);
}

TEST(ProtectiveField, TheRobotsMotionSinceTheScanCounts) {
  const ProtectiveField f = field_seeing(wall_at(0.8));
  EXPECT_NEAR(f.limit(0.5, 0.0, Pose2{0.2, 0, 0}).free_m, 0.28, 0.005);
  // Turned away by 90° since the scan: the wall is beside, not ahead.
  EXPECT_FALSE(f.limit(0.5, 0.0, Pose2{0, 0, std::numbers::pi / 2}).limited);
}

TEST(ProtectiveField, OnlyReturnsInTheSweptBandLimit) {
  // A wall parallel to the path, 1 cm beyond the body's side: driving along it is free.
  std::vector<Vec2> side;
  for (double x = 0.0; x < 3.0; x += 0.02) side.emplace_back(x, 0.31 + 0.02);
  EXPECT_FALSE(field_seeing(scan_of(side)).limit(0.8, 0.0, Pose2{}).limited);
  // Inside the body's width: limits.
  std::vector<Vec2> in_band;
  for (double x = 0.3; x < 3.0; x += 0.02) in_band.emplace_back(x, 0.25);
  EXPECT_TRUE(field_seeing(scan_of(in_band)).limit(0.8, 0.0, Pose2{}).limited);
}

TEST(ProtectiveField, AnArcIsCheckedAlongItsCurve) {
  // A post 0.8 m ahead: in the way straight on; a left turn of radius 0.5 m swings the body
  // clear of it, and a post on that curve limits the turn instead.
  const Vec2 ahead{0.8, 0.0};
  const double rho = 0.5, phi = 1.2;
  const Vec2 on_curve{rho * std::sin(phi), rho - rho * std::cos(phi)};  // 0.6 m along the arc
  const ProtectiveField a = field_seeing(scan_of({ahead}));
  EXPECT_TRUE(a.limit(0.4, 0.0, Pose2{}).limited);
  EXPECT_FALSE(a.limit(0.4, 0.4 / rho, Pose2{}).limited);
  const ProtectiveField b = field_seeing(scan_of({on_curve}));
  const FieldLimit l = b.limit(0.4, 0.4 / rho, Pose2{});
  ASSERT_TRUE(l.limited);
  // The body (0.32 m with the side margin) touches it when its centre is that far from it
  // along the circle: an angle acos(1 − b²/2ρ²) before.
  const double band = 0.32;
  EXPECT_NEAR(l.free_m, rho * (phi - std::acos(1 - band * band / (2 * rho * rho))), 0.01);
  // The same post mirrored limits the right turn alike, and not the left one.
  const ProtectiveField c = field_seeing(scan_of({{on_curve.x(), -on_curve.y()}}));
  EXPECT_NEAR(c.limit(0.4, -0.4 / rho, Pose2{}).free_m, l.free_m, 0.01);
  EXPECT_FALSE(c.limit(0.4, 0.4 / rho, Pose2{}).limited);
}

TEST(ProtectiveField, TurningInPlaceIsFreeReverseIsCappedNoScanIsBlocked) {
  const ProtectiveField f = field_seeing(wall_at(0.33));
  EXPECT_EQ(f.limit(0.5, 0.0, Pose2{}).forward_max_v, 0.0);
  EXPECT_EQ(f.limit(-0.5, 0.0, Pose2{}).reverse_max_v, 0.1);
  ProtectiveField none(ProtectiveFieldConfig{}, kMaxV, kAcc);
  EXPECT_EQ(none.limit(0.5, 0.0, Pose2{}).forward_max_v, 0.0);
  ProtectiveFieldConfig off;
  off.enabled = false;
  EXPECT_TRUE(std::isinf(field_seeing(wall_at(0.33), off).limit(0.5, 0.0, Pose2{}).forward_max_v));
}

TEST(ProtectiveField, ANonFiniteCommandIsBlockedAReturnBehindTheBodyIsNot) {
  const ProtectiveField open = field_seeing(wall_at(5.0));
  EXPECT_EQ(open.limit(0.5, std::numeric_limits<double>::quiet_NaN(), Pose2{}).forward_max_v, 0.0);
  EXPECT_EQ(open.limit(std::numeric_limits<double>::infinity(), 0.0, Pose2{}).forward_max_v, 0.0);
  // A return 0.1 m behind the body, on its line (a 270° laser, or the robot turned since the
  // scan): driving forward never reaches it.
  ProtectiveField f(ProtectiveFieldConfig{}, kMaxV, kAcc);
  const std::vector<std::uint16_t> r = scan_of({{0.4, 0.0}});
  f.on_scan(r.data(), r.size(), kAngleMin, kIncrement, Pose2{0, 0, std::numbers::pi});  // the laser faces backwards
  const FieldLimit l = f.limit(0.5, 0.0, Pose2{});
  EXPECT_FALSE(l.limited) << l.free_m;
  EXPECT_TRUE(std::isinf(l.forward_max_v));
  // ... while the same return ahead limits: 8 cm free, 3 cm beyond the margin.
  const FieldLimit ahead = field_seeing(r).limit(0.5, 0.0, Pose2{});
  EXPECT_TRUE(ahead.limited);
  EXPECT_NEAR(ahead.free_m, 0.08, 0.005);
  EXPECT_LT(ahead.forward_max_v, 0.2);
}

TEST(ProtectiveField, ConfigurationMustKeepTheFieldInsideTheLaserRange) {
  ProtectiveFieldConfig c;
  EXPECT_EQ(c.check(0.8, 0.8, 8.0), "");
  EXPECT_NE(c.check(3.0, 0.5, 8.0), "");  // 9 m to stop from 3 m/s at 0.5 m/s²
}

}  // namespace
}  // namespace cairn::firmware
