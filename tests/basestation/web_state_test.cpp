// The web view's JSON: robots from the fleet with the fusion's pose and 3σ ellipse, the
// status panel fields, a bounded trail; the command results kept; the map's geometry and
// PNG (base64) as mapper::render_png makes it.
#include "basestation/web/web_state.hpp"

#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace cairn::base {
namespace {

using nlohmann::json;

Fusion localised_fusion() {
  FusionConfig cfg;
  RobotPrior p;
  p.known = true;
  p.pose = {1.0, 2.0, 0.0};
  p.sigma = Vec3(0.1, 0.2, 0.01);  // x and y standard deviations: the 3σ ellipse is 0.6 x 0.3 m
  cfg.robots[1] = p;
  Fusion f(cfg);
  msg::OdometryIncrement o;
  o.robot_id = 1;
  o.seq = 1;
  o.t0 = 0;
  o.t1 = 10 * kNanosPerMilli;
  o.delta_cov = {1e-12, 0, 0, 0, 1e-12, 0, 0, 0, 1e-12};
  o.boot_epoch = 7;
  EXPECT_EQ(f.on_odometry(o), Fusion::Result::kApplied);
  return f;
}

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
  web.on_status(1, st);
  web.on_command_result(4, {1, 0.5, -0.25}, "accepted");
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
  EXPECT_EQ(r1["devices"][0]["name"], "lms");
  EXPECT_EQ(r1["devices"][0]["state"], 2);
  EXPECT_EQ(r1["pose"]["x"], 1.0);
  EXPECT_EQ(r1["pose"]["y"], 2.0);
  EXPECT_NEAR(r1["ellipse"]["major"].get<double>(), 0.6, 0.002);  // 3 x 0.2 m, along y
  EXPECT_NEAR(r1["ellipse"]["minor"].get<double>(), 0.3, 0.002);
  EXPECT_NEAR(std::abs(r1["ellipse"]["angle"].get<double>()), M_PI / 2, 0.002);
  EXPECT_EQ(r1["trail"], json::array({json::array({1.0, 2.0})}));
  const json& r2 = j["robots"][1];  // in the fleet, not in the fusion: no pose, no panel fields
  EXPECT_FALSE(r2.contains("pose"));
  EXPECT_FALSE(r2.contains("battery_v"));
  EXPECT_EQ(j["commands"], json::parse(R"([{"id":4,"robot":1,"x":0.5,"y":-0.25,"result":"accepted"}])"));
  EXPECT_EQ(j["explore"], false);
}

TEST(WebState, TheCommandHistoryIsBounded) {
  Fleet fleet(kNanosPerSecond, nullptr, {});
  WebState web;
  for (std::uint64_t i = 1; i <= 25; ++i) web.on_command_result(i, {1, 0, 0}, "refused: x");
  const json j = json::parse(web.state_json(0, fleet, nullptr, nullptr));
  ASSERT_EQ(j["commands"].size(), kWebCommandHistory);
  EXPECT_EQ(j["commands"][0]["id"], 16);  // the newest ten
  EXPECT_EQ(j["robots"], json::array());
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
  const json j = json::parse(WebState::map_json(g, 9));
  EXPECT_EQ(j["type"], "map");
  EXPECT_EQ(j["version"], 9);
  EXPECT_EQ(j["origin_x"], -1.0);
  EXPECT_EQ(j["resolution"], 0.5);
  EXPECT_EQ(j["width"], 3);
  EXPECT_EQ(j["height"], 2);
  // Decode the base64 and the PNG.
  const std::string text = j["png"];
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
}

}  // namespace
}  // namespace cairn::base
