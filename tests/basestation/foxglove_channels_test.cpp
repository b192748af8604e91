// The Foxglove channels built on the main loop: the channel list and its versions, the
// robots in the scene and their own pose topics, the grid's geometry and size cap.
#include "basestation/web/foxglove_channels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "tests/support/localised_fusion.hpp"

namespace cairn::base {
namespace {

using nlohmann::json;

Fusion localised_fusion() { return testing::localised_fusion(0.5); }

TEST(FoxgloveChannels, TheChannelsAndAPoseTopicPerLocalisedRobot) {
  Fleet fleet(3 * kNanosPerSecond, nullptr, {});
  fleet.on_status(1, "rover", "running", 1, kNanosPerSecond);
  fleet.on_status(2, "lost", "idle", 1, kNanosPerSecond);  // no prior: not localised, no pose topic
  const Fusion fusion = localised_fusion();
  FoxgloveChannels channels;
  const auto state = std::make_shared<const std::string>("{}");
  const auto a = channels.snapshot(fleet, &fusion, state, 5);
  ASSERT_EQ(a->channels.size(), 5u);
  const std::vector<std::string> topics{"/map", "/cairn/scene", "/cairn/robots/poses", "/cairn/state", "/cairn/robots/1/pose"};
  const std::vector<std::uint32_t> ids{1, 2, 3, 4, 1001};
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(a->channels[k].topic, topics[k]);
    EXPECT_EQ(a->channels[k].id, ids[k]);
    EXPECT_FALSE(a->channels[k].schema.empty());
  }
  EXPECT_EQ(a->channels[0].payload, nullptr);  // no map yet
  EXPECT_EQ(a->channels[3].payload, state);    // the web state's text as it is
  EXPECT_EQ(a->channels[4].schema_name, "foxglove.PoseInFrame");
  const json pose = json::parse(*a->channels[4].payload);
  EXPECT_EQ(pose["frame_id"], "map");
  EXPECT_NEAR(pose["pose"]["position"]["x"].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(pose["pose"]["orientation"]["z"].get<double>(), std::sin(0.25), 1e-6);  // yaw 0.5
  EXPECT_NEAR(pose["pose"]["orientation"]["w"].get<double>(), std::cos(0.25), 1e-6);
  const json poses = json::parse(*a->channels[2].payload);
  EXPECT_EQ(poses["poses"].size(), 1u);

  ClassGrid g;
  g.geometry.width = 2;
  g.geometry.height = 3;
  g.cells.assign(6, Cell::kClear);
  channels.set_map(g, 6);
  const auto b = channels.snapshot(fleet, &fusion, state, 7);
  ASSERT_NE(b->channels[0].payload, nullptr);
  EXPECT_EQ(b->channels[0].stamp_ns, 6u);
  const auto c = channels.snapshot(fleet, &fusion, state, 8);
  EXPECT_EQ(c->channels[0].version, b->channels[0].version);  // the same map: not sent again
  EXPECT_NE(c->channels[1].version, b->channels[1].version);  // a new scene
  EXPECT_NE(c->channels[1].version, c->channels[0].version);
}

TEST(FoxgloveChannels, TheSceneHasTheRobotWithItsEllipseAndDeletesTheOldOnes) {
  Fleet fleet(3 * kNanosPerSecond, nullptr, {});
  fleet.on_status(1, "rover", "running", 1, kNanosPerSecond);
  const Fusion fusion = localised_fusion();
  const json s = json::parse(foxglove_scene_json(fleet, &fusion, 3'000'000'001u));
  ASSERT_EQ(s["deletions"].size(), 1u);
  EXPECT_EQ(s["deletions"][0]["type"], 1);  // ALL
  ASSERT_EQ(s["entities"].size(), 1u);      // no landmarks yet: no landmark entity
  const json& e = s["entities"][0];
  EXPECT_EQ(e["id"], "robot/1");
  EXPECT_EQ(e["frame_id"], "map");
  EXPECT_EQ(e["timestamp"]["sec"], 3);
  EXPECT_EQ(e["timestamp"]["nsec"], 1);
  EXPECT_EQ(e["texts"][0]["text"], "1 rover");
  ASSERT_EQ(e["cylinders"].size(), 2u);
  const json& ellipse = e["cylinders"][1];
  EXPECT_NEAR(ellipse["size"]["x"].get<double>(), 1.2, 1e-3);  // 2 x 3σ along the major axis (y)
  EXPECT_NEAR(ellipse["size"]["y"].get<double>(), 0.6, 1e-3);
  EXPECT_NEAR(std::abs(ellipse["pose"]["orientation"]["z"].get<double>()), std::sin(M_PI / 4), 1e-3);  // major axis along y
  ASSERT_EQ(e["arrows"].size(), 1u);
  EXPECT_NEAR(e["arrows"][0]["pose"]["orientation"]["z"].get<double>(), std::sin(0.25), 1e-6);
  for (const char* k : {"spheres", "lines", "triangles", "models", "cubes"}) EXPECT_TRUE(e[k].is_array()) << k;
  // Without the fusion: nothing to show, the deletion still clears what was there.
  const json empty = json::parse(foxglove_scene_json(fleet, nullptr, 1));
  EXPECT_TRUE(empty["entities"].empty());
  EXPECT_EQ(empty["deletions"].size(), 1u);
}

TEST(FoxgloveChannels, AnEmptyOrTooBigMapIsNotSent) {
  ClassGrid empty;
  EXPECT_EQ(foxglove_grid_json(empty, 1), "");
  ClassGrid big;
  big.geometry.width = 1025;
  big.geometry.height = 1024;
  big.cells.assign(big.geometry.cells(), Cell::kUnknown);
  EXPECT_EQ(foxglove_grid_json(big, 1), "");
  FoxgloveChannels channels;
  channels.set_map(big, 1);
  EXPECT_EQ(channels.maps_too_big(), 1u);
  Fleet fleet(3 * kNanosPerSecond, nullptr, {});
  EXPECT_EQ(channels.snapshot(fleet, nullptr, nullptr, 2)->channels[0].payload, nullptr);
}

}  // namespace
}  // namespace cairn::base
