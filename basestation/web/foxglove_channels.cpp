#include "basestation/web/foxglove_channels.hpp"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "basestation/mapper/export.hpp"
#include "basestation/web/foxglove_schemas.hpp"
#include "basestation/web/web_state.hpp"

namespace cairn::base {

namespace {

using nlohmann::json;

constexpr const char* kFrame = "map";

json stamp(std::uint64_t ns) { return {{"sec", ns / 1'000'000'000u}, {"nsec", ns % 1'000'000'000u}}; }

json pose(double x, double y, double z, double yaw) {
  return {{"position", {{"x", x}, {"y", y}, {"z", z}}},
          {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(yaw / 2)}, {"w", std::cos(yaw / 2)}}}};
}

json colour(std::array<double, 3> rgb, double a) { return {{"r", rgb[0]}, {"g", rgb[1]}, {"b", rgb[2]}, {"a", a}}; }

// As map.png and the page: robot 1 red, 2 blue, 3 green, then orange, purple, teal.
std::array<double, 3> robot_colour(std::uint16_t robot) {
  static constexpr std::array<std::array<double, 3>, 6> kColours{
      {{0.86, 0.12, 0.12}, {0.12, 0.35, 0.86}, {0.08, 0.63, 0.16}, {0.78, 0.47, 0.0}, {0.59, 0.16, 0.71}, {0.0, 0.63, 0.67}}};
  return kColours[static_cast<std::size_t>(robot > 0 ? robot - 1 : 0) % kColours.size()];
}

json entity(const std::string& id, std::uint64_t ns) {
  return {{"timestamp", stamp(ns)}, {"frame_id", kFrame}, {"id", id},   {"lifetime", {{"sec", 0}, {"nsec", 0}}},
          {"frame_locked", false}, {"metadata", json::array()},        {"arrows", json::array()}, {"cubes", json::array()},
          {"spheres", json::array()}, {"cylinders", json::array()}, {"lines", json::array()},  {"triangles", json::array()},
          {"texts", json::array()}, {"models", json::array()}};
}

// A flat cylinder the size of the 3σ ellipse, its major axis along `angle`.
json ellipse_disc(double x, double y, const mapper::Ellipse& e, std::array<double, 3> rgb) {
  return {{"pose", pose(x, y, 0.005, e.angle)},
          {"size", {{"x", 2 * e.major}, {"y", 2 * e.minor}, {"z", 0.01}}},
          {"bottom_scale", 1.0},
          {"top_scale", 1.0},
          {"color", colour(rgb, 0.25)}};
}

struct LocalisedRobot {
  std::uint16_t id;
  std::string name;
  msg::PoseCorrection c;
};

std::vector<LocalisedRobot> localised(const Fleet& fleet, const Fusion* fusion) {
  std::vector<LocalisedRobot> out;
  if (!fusion) return out;
  for (const auto& [id, e] : fleet.robots()) {
    msg::PoseCorrection c;
    if (!fusion->correction(id, 0, &c)) continue;
    const Pose2& p = c.global_pose;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.theta)) continue;
    out.push_back({id, e.name, c});
  }
  return out;
}

std::string pose_in_frame_json(const Pose2& p, std::uint64_t ns) {
  return json{{"timestamp", stamp(ns)}, {"frame_id", kFrame}, {"pose", pose(p.x, p.y, 0, p.theta)}}.dump();
}

}  // namespace

std::string foxglove_grid_json(const ClassGrid& grid, std::uint64_t stamp_ns) {
  const GridGeometry& g = grid.geometry;
  if (g.width <= 0 || g.height <= 0 || g.cells() > kFoxgloveMaxGridCells || grid.cells.size() != g.cells()) return {};
  std::vector<std::uint8_t> rgba(g.cells() * 4);
  for (std::size_t k = 0; k < g.cells(); ++k) {
    const Cell c = grid.cells[k];
    const std::uint8_t v = c == Cell::kObstacle ? 0 : c == Cell::kClear ? 255 : 190;  // as render_png
    rgba[4 * k] = rgba[4 * k + 1] = rgba[4 * k + 2] = v;
    rgba[4 * k + 3] = c == Cell::kUnknown ? 128 : 255;
  }
  constexpr int kUint8 = 1;  // foxglove.NumericType UINT8
  json fields = json::array();
  int offset = 0;
  for (const char* name : {"red", "green", "blue", "alpha"}) fields.push_back({{"name", name}, {"offset", offset++}, {"type", kUint8}});
  std::string text = json{{"timestamp", stamp(stamp_ns)},
                          {"frame_id", kFrame},
                          {"pose", pose(g.origin_x, g.origin_y, 0, 0)},
                          {"column_count", g.width},
                          {"cell_size", {{"x", g.resolution}, {"y", g.resolution}}},
                          {"row_stride", 4 * g.width},
                          {"cell_stride", 4},
                          {"fields", std::move(fields)},
                          {"data", ""}}
                         .dump();
  // The cells go in after: base64 needs no escaping, and the JSON writer's escaping pass over
  // megabytes was most of the time on the main loop.
  constexpr std::string_view kEmptyData = R"("data":"")";
  const std::size_t at = text.find(kEmptyData);
  text.insert(at + kEmptyData.size() - 1, base64(rgba));
  return text;
}

std::string foxglove_scene_json(const Fleet& fleet, const Fusion* fusion, std::uint64_t stamp_ns) {
  json entities = json::array();
  for (const LocalisedRobot& r : localised(fleet, fusion)) {
    const Pose2& p = r.c.global_pose;
    const auto rgb = robot_colour(r.id);
    json e = entity("robot/" + std::to_string(r.id), stamp_ns);
    e["metadata"].push_back({{"key", "name"}, {"value", r.name}});
    e["cylinders"].push_back({{"pose", pose(p.x, p.y, 0.05, 0)},
                              {"size", {{"x", 0.3}, {"y", 0.3}, {"z", 0.1}}},
                              {"bottom_scale", 1.0},
                              {"top_scale", 1.0},
                              {"color", colour(rgb, 1.0)}});
    const auto& cov = r.c.global_cov;
    e["cylinders"].push_back(ellipse_disc(p.x, p.y, mapper::covariance_ellipse({cov[0], cov[1], cov[3], cov[4]}, 3.0), rgb));
    e["arrows"].push_back({{"pose", pose(p.x, p.y, 0.12, p.theta)},
                           {"shaft_length", 0.25},
                           {"shaft_diameter", 0.04},
                           {"head_length", 0.1},
                           {"head_diameter", 0.1},
                           {"color", colour(rgb, 1.0)}});
    e["texts"].push_back({{"pose", pose(p.x, p.y, 0.4, 0)},
                          {"billboard", true},
                          {"font_size", 14.0},
                          {"scale_invariant", true},
                          {"color", colour({1, 1, 1}, 1.0)},
                          {"text", std::to_string(r.id) + " " + r.name}});
    entities.push_back(std::move(e));
  }
  if (fusion) {
    std::vector<msg::Landmark> all;
    fusion->landmarks(&all);
    json e = entity("landmarks", stamp_ns);
    constexpr std::array<double, 3> kMagenta{0.9, 0.0, 0.78};  // as map.png
    for (std::size_t i = 0; i < all.size() && i < kFoxgloveMaxLandmarks; ++i) {
      const msg::Landmark& l = all[i];
      if (!std::isfinite(l.x) || !std::isfinite(l.y)) continue;
      e["cubes"].push_back({{"pose", pose(l.x, l.y, 0.05, 0)}, {"size", {{"x", 0.08}, {"y", 0.08}, {"z", 0.1}}}, {"color", colour(kMagenta, 1.0)}});
      e["cylinders"].push_back(ellipse_disc(l.x, l.y, mapper::covariance_ellipse(l.cov, 3.0), kMagenta));
    }
    if (!e["cubes"].empty()) entities.push_back(std::move(e));
  }
  constexpr int kDeleteAll = 1;  // foxglove.SceneEntityDeletionType ALL: robots that left go too
  return json{{"deletions", json::array({{{"timestamp", stamp(stamp_ns)}, {"type", kDeleteAll}, {"id", ""}}})},
              {"entities", std::move(entities)}}
      .dump();
}

void FoxgloveChannels::set_map(const ClassGrid& grid, std::uint64_t stamp_ns) {
  std::string text = foxglove_grid_json(grid, stamp_ns);
  if (text.empty()) {
    ++maps_too_big_;
    return;
  }
  map_.payload = std::make_shared<const std::string>(std::move(text));
  map_.version = next_version_++;
  map_.stamp_ns = stamp_ns;
}

std::shared_ptr<const FoxgloveSnapshot> FoxgloveChannels::snapshot(const Fleet& fleet, const Fusion* fusion,
                                                                   std::shared_ptr<const std::string> state_json,
                                                                   std::uint64_t stamp_ns) {
  auto snap = std::make_shared<FoxgloveSnapshot>();
  auto add = [&](std::uint32_t id, std::string topic, std::string name, std::string_view schema,
                 std::shared_ptr<const std::string> payload) {
    FoxgloveChannel c{id, std::move(topic), std::move(name), schema, std::move(payload), 0, stamp_ns};
    if (c.payload) c.version = next_version_++;
    snap->channels.push_back(std::move(c));
  };
  FoxgloveChannel map = map_;
  map.id = kFoxgloveMapChannel;
  map.topic = "/map";
  map.schema_name = "foxglove.Grid";
  map.schema = foxglove_schema::grid();
  snap->channels.push_back(std::move(map));
  add(kFoxgloveSceneChannel, "/cairn/scene", "foxglove.SceneUpdate", foxglove_schema::scene_update(),
      std::make_shared<const std::string>(foxglove_scene_json(fleet, fusion, stamp_ns)));
  const std::vector<LocalisedRobot> robots = localised(fleet, fusion);
  json poses = json::array();
  for (const LocalisedRobot& r : robots) poses.push_back(pose(r.c.global_pose.x, r.c.global_pose.y, 0, r.c.global_pose.theta));
  add(kFoxglovePosesChannel, "/cairn/robots/poses", "foxglove.PosesInFrame", foxglove_schema::poses_in_frame(),
      std::make_shared<const std::string>(json{{"timestamp", stamp(stamp_ns)}, {"frame_id", kFrame}, {"poses", std::move(poses)}}.dump()));
  add(kFoxgloveStateChannel, "/cairn/state", "cairn.WebState", foxglove_schema::web_state(), std::move(state_json));
  for (const LocalisedRobot& r : robots)
    add(kFoxgloveRobotPoseChannelBase + r.id, "/cairn/robots/" + std::to_string(r.id) + "/pose", "foxglove.PoseInFrame",
        foxglove_schema::pose_in_frame(), std::make_shared<const std::string>(pose_in_frame_json(r.c.global_pose, stamp_ns)));
  return snap;
}

}  // namespace cairn::base
