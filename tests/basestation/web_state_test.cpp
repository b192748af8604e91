// The web view's JSON: robots from the fleet with the fusion's pose and 3σ ellipse, the
// status panel fields with the RT loop's, a bounded trail, the task with its region and the
// latest bid; the exploration's state; the command results kept; the map's geometry, PNG
// (base64) as mapper::render_png makes it, and frontier cells.
#include "basestation/web/web_map_tiles.hpp"
#include "basestation/web/web_state.hpp"

#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "tests/support/localised_fusion.hpp"

namespace cairn::base {
namespace {

using nlohmann::json;

Fusion localised_fusion() { return testing::localised_fusion(0.0); }

TEST(WebState, RobotsCarryTheFleetTheStatusAndTheFusionsEstimate) {
  Fleet fleet(3 * kNanosPerSecond, nullptr, {});
  fleet.on_status(1, "rover", "running", 1, kNanosPerSecond);
  fleet.on_status(2, "other", "idle", 1, kNanosPerSecond);
  const Fusion fusion = localised_fusion();
  WebState web;
  WebRobotStatus st;
  st.battery_voltage = 24.5f;
  st.battery_soc = 0.5f;
  st.stop_reason = 1;  // the e-stop
  st.devices.push_back({"lms", "scanning", 2});
  st.loop_period_mean_us = 10000.25f;
  st.loop_period_p99_us = 10090.5f;
  st.loop_jitter_max_us = 210.0f;
  st.loop_cycles = 4200;
  st.deadline_misses = 3;
  st.queue_overflows = 1;
  web.on_status(1, st);
  web.on_command_result(4, {WebCommandKind::kVisit, 1, 0.5, -0.25, false}, "accepted");
  const json j = json::parse(web.state_json(3 * kNanosPerSecond / 2, fleet, &fusion, nullptr));
  EXPECT_EQ(j["type"], "state");
  ASSERT_EQ(j["robots"].size(), 2u);
  const json& r1 = j["robots"][0];
  EXPECT_EQ(r1["id"], 1);
  EXPECT_EQ(r1["name"], "rover");
  EXPECT_EQ(r1["mode"], "running");
  EXPECT_EQ(r1["presence"], "alive");
  EXPECT_EQ(r1["link_age_s"], 0.5);
  EXPECT_EQ(r1["battery_v"], 24.5);
  EXPECT_EQ(r1["stop"], "e-stop pressed");
  EXPECT_EQ(r1["estop"], true);
  EXPECT_EQ(r1["reset_required"], false);  // pressed, not yet latched-and-released
  EXPECT_EQ(r1["devices"][0]["name"], "lms");
  EXPECT_EQ(r1["devices"][0]["state"], 2);
  EXPECT_EQ(r1["rt"], json::parse(R"({"period_mean_us":10000.25,"period_p99_us":10090.5,"jitter_max_us":210.0,)"
                                   R"("cycles":4200,"misses":3,"overflows":1})"));
  EXPECT_EQ(r1["pose"]["x"], 1.0);
  EXPECT_EQ(r1["pose"]["y"], 2.0);
  EXPECT_NEAR(r1["ellipse"]["major"].get<double>(), 0.6, 0.002);  // 3 x 0.2 m, along y
  EXPECT_NEAR(r1["ellipse"]["minor"].get<double>(), 0.3, 0.002);
  EXPECT_NEAR(std::abs(r1["ellipse"]["angle"].get<double>()), M_PI / 2, 0.002);
  EXPECT_EQ(r1["trail"], json::array({json::array({1.0, 2.0})}));
  const json& r2 = j["robots"][1];  // in the fleet, not in the fusion: no pose, no panel fields
  EXPECT_FALSE(r2.contains("pose"));
  EXPECT_FALSE(r2.contains("battery_v"));
  EXPECT_EQ(j["commands"], json::parse(R"([{"id":4,"cmd":"visit","robot":1,"x":0.5,"y":-0.25,"result":"accepted"}])"));
  EXPECT_EQ(j["explore"], false);
  EXPECT_TRUE(j["exploration"].is_null());
}

// The exploration's part: each robot's task with its information-gain region, its latest
// bid (items and unreachable clusters), and whether the operator stopped exploration.
TEST(WebState, TasksCarryTheirRegionAndRobotsTheirLatestBid) {
  Fleet fleet(3 * kNanosPerSecond, nullptr, {});
  fleet.on_status(1, "rover", "running", 1, kNanosPerSecond);
  explore::AllocatorConfig cfg;
  cfg.bid_wait = kNanosPerSecond / 2;
  cfg.cells_per_metre = 1.0;
  cfg.min_gain = 20;
  explore::TaskAllocator alloc(cfg);
  msg::Bid bid;
  bid.robot_id = 1;
  bid.seq = 5;
  bid.n_items = 2;
  bid.items[0] = {3.0, 4.0, 120.0, 2.5, 2.0, 3.0, 4.0, 5.0};
  bid.items[1] = {-1.0, 0.5, 40.0, 6.0, -2.0, 0.0, 0.0, 1.0};
  bid.n_unreachable = 1;
  bid.unreachable[0] = {7.0, 7.5, 6.5, 7.0, 7.5, 8.0, 12, msg::UnreachableKind::kTooNarrow};
  ASSERT_TRUE(alloc.on_bid(bid, 0));
  std::vector<msg::TaskAssignment> out;
  alloc.tick(kNanosPerSecond, &out);
  ASSERT_EQ(out.size(), 1u);
  WebState web;
  json j = json::parse(web.state_json(kNanosPerSecond, fleet, nullptr, &alloc));
  const json& r1 = j["robots"][0];
  EXPECT_EQ(r1["task"]["kind"], "explore");
  EXPECT_EQ(r1["task"]["x"], 3.0);
  EXPECT_EQ(r1["task"]["gain"], 120.0);
  EXPECT_EQ(r1["task"]["igr"], json::parse("[2.0, 3.0, 4.0, 5.0]"));
  EXPECT_EQ(r1["bid"]["seq"], 5);
  ASSERT_EQ(r1["bid"]["items"].size(), 2u);
  EXPECT_EQ(r1["bid"]["items"][1], json::parse(R"({"x":-1.0,"y":0.5,"gain":40.0,"cost":6.0,"igr":[-2.0,0.0,0.0,1.0]})"));
  EXPECT_EQ(r1["bid"]["unreachable"][0], json::parse(R"({"x":7.0,"y":7.5,"rect":[6.5,7.0,7.5,8.0],"cells":12})"));
  EXPECT_EQ(j["explore"], true);
  EXPECT_EQ(j["exploration"]["paused"], false);
  EXPECT_EQ(j["exploration"]["rounds"], 1);
  alloc.set_paused(true, 2 * kNanosPerSecond);
  out.clear();
  alloc.tick(2 * kNanosPerSecond, &out);
  j = json::parse(web.state_json(2 * kNanosPerSecond, fleet, nullptr, &alloc));
  EXPECT_EQ(j["exploration"]["paused"], true);
  EXPECT_EQ(j["robots"][0]["task"]["kind"], "idle");
  EXPECT_FALSE(j["robots"][0]["task"].contains("igr"));
}

// A reset's result arrives twice: "under way" when asked, its outcome when the exchange ends.
TEST(WebState, ALaterResultForTheSameCommandReplacesTheFirst) {
  Fleet fleet(kNanosPerSecond, nullptr, {});
  WebState web;
  const WebCommand reset{WebCommandKind::kReset, 2, 0, 0, false};
  web.on_command_result(7, reset, "reset under way");
  web.on_command_result(8, {WebCommandKind::kExplore, 0, 0, 0, true}, "exploration running");
  web.on_command_result(7, reset, "done: reset accepted");
  const json j = json::parse(web.state_json(0, fleet, nullptr, nullptr));
  ASSERT_EQ(j["commands"].size(), 2u);
  EXPECT_EQ(j["commands"][0], json::parse(R"({"id":7,"cmd":"reset","robot":2,"result":"done: reset accepted"})"));
  EXPECT_EQ(j["commands"][1], json::parse(R"({"id":8,"cmd":"explore","run":true,"result":"exploration running"})"));
}

TEST(WebState, TheCommandHistoryIsBounded) {
  Fleet fleet(kNanosPerSecond, nullptr, {});
  WebState web;
  for (std::uint64_t i = 1; i <= 25; ++i) web.on_command_result(i, {WebCommandKind::kVisit, 1, 0, 0, false}, "refused: x");
  const json j = json::parse(web.state_json(0, fleet, nullptr, nullptr));
  ASSERT_EQ(j["commands"].size(), kWebCommandHistory);
  EXPECT_EQ(j["commands"][0]["id"], 16);  // the newest ten
  EXPECT_EQ(j["robots"], json::array());
}

// Frontier cells: clear with an unknown 4-neighbour; a clear cell among clear and obstacle
// cells, or an unknown one, is not; the map's edge is not unknown.
TEST(WebState, FrontierCellsAreClearCellsBesideUnknownOnes) {
  ClassGrid g;
  g.geometry.resolution = 1.0;
  g.geometry.width = 4;
  g.geometry.height = 3;
  g.cells.assign(12, Cell::kClear);
  g.at(3, 2) = Cell::kUnknown;   // its neighbours (2, 2) and (3, 1) are frontier
  g.at(0, 0) = Cell::kObstacle;
  g.at(1, 1) = Cell::kUnknown;   // (1, 0), (0, 1), (2, 1), (1, 2)
  WebMapTiles tiles;
  const json j = json::parse(tiles.update(g)->message_since(0));
  std::vector<int> cells = j["frontier"].get<std::vector<int>>();
  std::sort(cells.begin(), cells.end());
  EXPECT_EQ(cells, (std::vector<int>{1, 4, 6, 7, 9, 10}));  // j * 4 + i
  EXPECT_EQ(j["frontier_total"], 6);
}

TEST(WebState, Base64MatchesTheStandardVectors) {
  const auto b = [](std::string_view s) { return base64(std::vector<std::uint8_t>(s.begin(), s.end())); };
  EXPECT_EQ(b(""), "");
  EXPECT_EQ(b("f"), "Zg==");
  EXPECT_EQ(b("fo"), "Zm8=");
  EXPECT_EQ(b("foo"), "Zm9v");
  EXPECT_EQ(b("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64({0xff, 0xfe, 0x00}), "//4A");
}

// Tiles of 64 x 64 cells, each with the version it last changed in: a socket that saw
// version v gets only the newer tiles; the same map again is the same snapshot; a new
// geometry sends everything again ("full").
TEST(WebMapTiles, OnlyTheTilesThatChangedGoAgain) {
  ClassGrid g;
  g.geometry.resolution = 0.15;
  g.geometry.width = 70;  // two tiles across: 64 + 6 cells
  g.geometry.height = 130;  // three up: 64 + 64 + 2
  g.cells.assign(70 * 130, Cell::kUnknown);
  WebMapTiles tiles;
  const auto first = tiles.update(g);
  json j = json::parse(first->message_since(0));
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["tile"], kWebTileCells);
  ASSERT_EQ(j["tiles"].size(), 6u);
  EXPECT_EQ(tiles.tiles_encoded(), 6u);
  EXPECT_EQ(tiles.update(g), first) << "an unchanged map is the same snapshot";
  EXPECT_EQ(tiles.tiles_encoded(), 6u);
  g.at(66, 129) = Cell::kObstacle;  // in tile (1, 2), the 6 x 2 corner
  const auto second = tiles.update(g);
  EXPECT_EQ(second->version, 2u);
  j = json::parse(second->message_since(1));
  EXPECT_EQ(j["full"], false);
  ASSERT_EQ(j["tiles"].size(), 1u);
  EXPECT_EQ(j["tiles"][0]["tx"], 1);
  EXPECT_EQ(j["tiles"][0]["ty"], 2);
  EXPECT_EQ(json::parse(second->message_since(2))["tiles"].size(), 0u);
  EXPECT_EQ(json::parse(second->message_since(0))["tiles"].size(), 6u) << "a new socket gets them all";
  EXPECT_EQ(tiles.tiles_encoded(), 7u);
  // The frontier rides along: a clear cell beside unknown ones.
  g.at(0, 0) = Cell::kClear;
  j = json::parse(tiles.update(g)->message_since(2));
  EXPECT_EQ(j["frontier"], json::array({0}));
  // A new geometry (the mapper grew the map): every tile again, marked full.
  g.geometry.origin_x = -1.0;
  const auto moved = tiles.update(g);
  j = json::parse(moved->message_since(3));
  EXPECT_EQ(j["full"], true);
  EXPECT_EQ(j["tiles"].size(), 6u);
  EXPECT_EQ(j["origin_x"], -1.0);
}

TEST(WebState, TheMapIsAPngOfOnePixelPerCellWithItsGeometry) {
  ClassGrid g;
  g.geometry.origin_x = -1.0;
  g.geometry.origin_y = 2.0;
  g.geometry.resolution = 0.5;
  g.geometry.width = 3;
  g.geometry.height = 2;
  g.cells.assign(6, Cell::kUnknown);
  g.at(0, 0) = Cell::kObstacle;  // lower-left: the image's bottom-left pixel
  g.at(2, 1) = Cell::kClear;     // upper-right: its top-right pixel
  WebMapTiles tiles;
  const json j = json::parse(tiles.update(g)->message_since(0));
  EXPECT_EQ(j["type"], "map");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["full"], true);
  ASSERT_EQ(j["tiles"].size(), 1u);  // 3 x 2 cells: one tile
  EXPECT_EQ(j["tiles"][0]["tx"], 0);
  EXPECT_EQ(j["origin_x"], -1.0);
  EXPECT_EQ(j["resolution"], 0.5);
  EXPECT_EQ(j["width"], 3);
  EXPECT_EQ(j["height"], 2);
  // Decode the base64 and the PNG.
  const std::string text = j["tiles"][0]["png"];
  std::vector<std::uint8_t> bytes;
  std::uint32_t acc = 0;
  int bits = 0;
  for (const char c : text) {
    if (c == '=') break;
    const std::string_view alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    acc = (acc << 6) | static_cast<std::uint32_t>(alphabet.find(c));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bytes.push_back(static_cast<std::uint8_t>((acc >> bits) & 0xff));
    }
  }
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_memory(&img, bytes.data(), bytes.size())) << img.message;
  img.format = PNG_FORMAT_GRAY;
  std::vector<std::uint8_t> px(PNG_IMAGE_SIZE(img));
  ASSERT_TRUE(png_image_finish_read(&img, nullptr, px.data(), 0, nullptr)) << img.message;
  ASSERT_EQ(img.width, 3u);
  ASSERT_EQ(img.height, 2u);
  EXPECT_EQ(px[3 + 0], 0);    // bottom-left: obstacle black
  EXPECT_EQ(px[2], 255);      // top-right: clear white
  EXPECT_EQ(px[0], 190);      // unknown grey
  // The frontier: the clear cell (2, 1) has unknown neighbours (1, 1) and (2, 0).
  EXPECT_EQ(j["frontier"], json::array({5}));
  EXPECT_EQ(j["frontier_total"], 1);
}

}  // namespace
}  // namespace cairn::base
