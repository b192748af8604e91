// cairn-base's configuration: the fusion robustness keys are read strictly (ranges, unknown
// keys), and the map frame must come from the configuration.
#include "basestation/base_config.hpp"

#include <gtest/gtest.h>

#include "common/config.hpp"

namespace cairn::base {
namespace {

constexpr const char* kFleet = "[[robot]]\nid = 1\ninitial_pose = [0.0, 0.0, 0.0]\n";

TEST(BaseConfig, ReadsTheFusionRobustnessKeys) {
  const BaseConfig c = parse_base_config(std::string(R"(
[fusion]
max_landmarks = 500
landmark_confirm_count = 4
landmark_confirm_age = 60
relocation_margin = 2
restart_sigma = [0.5, 0.5, 0.1]
max_step_m = 2.0
max_step_rad = 1.0
max_coordinate_m = 1000.0
max_variance = 50.0
max_range_m = 40.0
max_seq_gap = 500
innovation_confidence = 0.999
[unknown_robot]
allow = true
max_robots = 2
)") + kFleet, "base.toml");
  const FusionConfig& f = c.fusion;
  EXPECT_EQ(f.max_landmarks, 500u);
  EXPECT_EQ(f.landmark_confirm_count, 4u);
  EXPECT_EQ(f.landmark_confirm_age, 60u);
  EXPECT_EQ(f.jcbb.relocation_margin, 2);
  EXPECT_DOUBLE_EQ(f.restart_sigma.x(), 0.5);
  EXPECT_DOUBLE_EQ(f.limits.max_step_m, 2.0);
  EXPECT_DOUBLE_EQ(f.limits.max_step_rad, 1.0);
  EXPECT_DOUBLE_EQ(f.limits.max_coordinate_m, 1000.0);
  EXPECT_DOUBLE_EQ(f.limits.max_variance, 50.0);
  EXPECT_DOUBLE_EQ(f.limits.max_range_m, 40.0);
  EXPECT_EQ(f.limits.max_seq_gap, 500u);
  EXPECT_DOUBLE_EQ(f.limits.innovation_confidence, 0.999);
  EXPECT_TRUE(f.allow_unknown_robots);
  EXPECT_EQ(f.max_unknown_robots, 2u);
}

TEST(BaseConfig, DefaultsRefuseUnknownRobots) {
  const BaseConfig c = parse_base_config(kFleet, "base.toml");
  EXPECT_FALSE(c.fusion.allow_unknown_robots);
  EXPECT_EQ(c.fusion.max_landmarks, 2000u);
  EXPECT_EQ(c.fusion.limits.max_seq_gap, 10000u);
}

TEST(BaseConfig, OutOfRangeAndUnknownKeysAreErrors) {
  EXPECT_THROW(parse_base_config(std::string("[fusion]\nmax_landmarks = 0\n") + kFleet, "a.toml"), ConfigError);
  EXPECT_THROW(parse_base_config(std::string("[fusion]\ninnovation_confidence = 1.5\n") + kFleet, "b.toml"), ConfigError);
  EXPECT_THROW(parse_base_config(std::string("[fusion]\nrestart_sigma = [0.1, -1.0, 0.1]\n") + kFleet, "c.toml"), ConfigError);
  EXPECT_THROW(parse_base_config(std::string("[unknown_robot]\nalow = true\n") + kFleet, "d.toml"), ConfigError);
}

TEST(BaseConfig, ExplorationIsOffByDefaultAndItsKeysAreRead) {
  EXPECT_FALSE(parse_base_config(kFleet, "base.toml").explore_enabled);
  const BaseConfig c = parse_base_config(std::string("[explore]\nenabled = true\nbid_wait_s = 0.2\nmin_gain = 35\n"
                                                    "cells_per_metre = 4\nhysteresis_ratio = 0.9\ncoordinated = false\n"
                                                    "look_radius_m = 1.5\ngive_up_attempts = 3\n") +
                                             kFleet,
                                         "base.toml");
  EXPECT_TRUE(c.explore_enabled);
  EXPECT_EQ(c.explore.bid_wait, 200 * kNanosPerMilli);
  EXPECT_DOUBLE_EQ(c.explore.min_gain, 35);
  EXPECT_DOUBLE_EQ(c.explore.cells_per_metre, 4);
  EXPECT_DOUBLE_EQ(c.explore.hysteresis_ratio, 0.9);
  EXPECT_FALSE(c.explore.coordinated);
  EXPECT_DOUBLE_EQ(c.explore.look_radius_m, 1.5);
  EXPECT_EQ(c.explore.give_up_attempts, 3u);
  // A look radius inside the arrival radius would let an arrival go uncounted.
  EXPECT_THROW(parse_base_config(std::string("[explore]\nlook_radius_m = 0.1\n") + kFleet, "look.toml"), ConfigError);
  // Robots go home at the end by default: the listed robots with a known start pose.
  const BaseConfig two = parse_base_config(std::string("[explore]\nenabled = true\n") + kFleet +
                                               "[[robot]]\nid = 2\ninitial_pose = [1.5, -2.0, 0.3]\n[[robot]]\nid = 3\n",
                                           "home.toml");
  ASSERT_EQ(two.explore.home.size(), 2u);
  EXPECT_TRUE(two.explore.home.at(2).isApprox(Vec2(1.5, -2.0)));
  EXPECT_EQ(two.explore.home.count(3), 0u);  // no initial_pose: no home to go back to
  EXPECT_TRUE(parse_base_config(std::string("[explore]\nenabled = true\nreturn_home = false\n") + kFleet, "nohome.toml")
                  .explore.home.empty());
  EXPECT_THROW(parse_base_config(std::string("[explore]\nhysteresis_ratio = 0\n") + kFleet, "e.toml"), ConfigError);
  EXPECT_THROW(parse_base_config(std::string("[explore]\nbid_wiat_s = 1\n") + kFleet, "f.toml"), ConfigError);
  try {
    parse_base_config(std::string("[fusion]\nenabled = false\n[explore]\nenabled = true\n"), "g.toml");
    FAIL() << "exploration without fusion was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("needs [fusion]"), std::string::npos) << e.what();
  }
}

TEST(BaseConfig, TheMapFrameMustComeFromTheConfiguration) {
  // Fusion on, but no listed robot with a start pose: nothing defines the frame.
  EXPECT_THROW(parse_base_config("[[robot]]\nid = 2\n", "e.toml"), ConfigError);
  EXPECT_THROW(parse_base_config("[unknown_robot]\nallow = true\n", "f.toml"), ConfigError);
  EXPECT_NO_THROW(parse_base_config("[fusion]\nenabled = false\n", "g.toml"));
}

}  // namespace
}  // namespace cairn::base

namespace cairn::base {
namespace {

TEST(BaseConfig, TheWebViewIsOffByDefaultOnLoopbackAndNeedsAToken) {
  const BaseConfig off = parse_base_config(kFleet, "base.toml");
  EXPECT_FALSE(off.web.enabled);
  EXPECT_EQ(off.web.listen, "127.0.0.1");
  const BaseConfig on = parse_base_config(std::string("[web]\nenabled = true\nport = 8123\ntoken = \"abcdefghijklmnop\"\n"
                                                      "map_period_s = 1.5\n") + kFleet, "web.toml");
  EXPECT_TRUE(on.web.enabled);
  EXPECT_EQ(on.web.listen, "127.0.0.1");
  EXPECT_EQ(on.web.port, 8123);
  EXPECT_EQ(on.web.token, "abcdefghijklmnop");
  EXPECT_EQ(on.web.map_period, 1500 * kNanosPerMilli);
  EXPECT_EQ(parse_base_config(std::string("[web]\nlisten = \"::1\"\n") + kFleet, "v6.toml").web.listen, "::1");
}

TEST(BaseConfig, BadWebViewKeysAreClearErrors) {
  const auto error = [](const std::string& web) {
    try {
      (void)parse_base_config("[web]\n" + web + kFleet, "web.toml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("enabled = true\n").find("token of at least 16"), std::string::npos) << error("enabled = true\n");
  EXPECT_NE(error("enabled = true\ntoken = \"short\"\n").find("token"), std::string::npos);
  EXPECT_NE(error("token = \"has spaces in it ok?\"\n").find("letters, digits"), std::string::npos);
  EXPECT_NE(error("listen = \"localhost\"\n").find("IPv4 or IPv6"), std::string::npos);
  EXPECT_NE(error("port = 70000\n").find("port"), std::string::npos);
  EXPECT_NE(error("prot = 80\n").find("prot"), std::string::npos);
  EXPECT_NE(error("map_period_s = 0\n").find("map_period_s"), std::string::npos);
}

}  // namespace
}  // namespace cairn::base
