#include "basestation/web/foxglove_schemas.hpp"

#include <nlohmann/json.hpp>
#include <string>

namespace cairn::base::foxglove_schema {

namespace {

using nlohmann::json;

json object(const char* title, json properties) {
  json required = json::array();
  for (const auto& [k, v] : properties.items()) required.push_back(k);
  return {{"title", title}, {"type", "object"}, {"properties", std::move(properties)}, {"required", std::move(required)}};
}
json number() { return {{"type", "number"}}; }
json integer() { return {{"type", "integer"}, {"minimum", 0}}; }
json string() { return {{"type", "string"}}; }
json boolean() { return {{"type", "boolean"}}; }
json array_of(json items) { return {{"type", "array"}, {"items", std::move(items)}}; }

json time() { return object("time", {{"sec", integer()}, {"nsec", integer()}}); }
json vector2() { return object("foxglove.Vector2", {{"x", number()}, {"y", number()}}); }
json vector3() { return object("foxglove.Vector3", {{"x", number()}, {"y", number()}, {"z", number()}}); }
json point3() { return object("foxglove.Point3", {{"x", number()}, {"y", number()}, {"z", number()}}); }
json quaternion() { return object("foxglove.Quaternion", {{"x", number()}, {"y", number()}, {"z", number()}, {"w", number()}}); }
json pose() { return object("foxglove.Pose", {{"position", vector3()}, {"orientation", quaternion()}}); }
json color() { return object("foxglove.Color", {{"r", number()}, {"g", number()}, {"b", number()}, {"a", number()}}); }

json packed_element_field() {
  // NumericType as its integer value (UINT8 = 1 ... FLOAT64 = 8).
  return object("foxglove.PackedElementField",
                {{"name", string()}, {"offset", integer()}, {"type", {{"type", "integer"}, {"minimum", 0}, {"maximum", 8}}}});
}

json grid_schema() {
  return object("foxglove.Grid", {{"timestamp", time()},
                                  {"frame_id", string()},
                                  {"pose", pose()},
                                  {"column_count", integer()},
                                  {"cell_size", vector2()},
                                  {"row_stride", integer()},
                                  {"cell_stride", integer()},
                                  {"fields", array_of(packed_element_field())},
                                  {"data", {{"type", "string"}, {"contentEncoding", "base64"}}}});
}

json scene_update_schema() {
  const json arrow = object("foxglove.ArrowPrimitive", {{"pose", pose()},
                                                        {"shaft_length", number()},
                                                        {"shaft_diameter", number()},
                                                        {"head_length", number()},
                                                        {"head_diameter", number()},
                                                        {"color", color()}});
  const json cube = object("foxglove.CubePrimitive", {{"pose", pose()}, {"size", vector3()}, {"color", color()}});
  const json sphere = object("foxglove.SpherePrimitive", {{"pose", pose()}, {"size", vector3()}, {"color", color()}});
  const json cylinder = object("foxglove.CylinderPrimitive", {{"pose", pose()},
                                                              {"size", vector3()},
                                                              {"bottom_scale", number()},
                                                              {"top_scale", number()},
                                                              {"color", color()}});
  const json line = object("foxglove.LinePrimitive", {{"type", {{"type", "integer"}, {"minimum", 0}, {"maximum", 2}}},
                                                      {"pose", pose()},
                                                      {"thickness", number()},
                                                      {"scale_invariant", boolean()},
                                                      {"points", array_of(point3())},
                                                      {"color", color()},
                                                      {"colors", array_of(color())},
                                                      {"indices", array_of(integer())}});
  const json text = object("foxglove.TextPrimitive", {{"pose", pose()},
                                                      {"billboard", boolean()},
                                                      {"font_size", number()},
                                                      {"scale_invariant", boolean()},
                                                      {"color", color()},
                                                      {"text", string()}});
  const json triangle = object("foxglove.TriangleListPrimitive", {{"pose", pose()},
                                                                  {"points", array_of(point3())},
                                                                  {"color", color()},
                                                                  {"colors", array_of(color())},
                                                                  {"indices", array_of(integer())}});
  const json model = object("foxglove.ModelPrimitive", {{"pose", pose()},
                                                        {"scale", vector3()},
                                                        {"color", color()},
                                                        {"override_color", boolean()},
                                                        {"url", string()},
                                                        {"media_type", string()},
                                                        {"data", {{"type", "string"}, {"contentEncoding", "base64"}}}});
  const json entity = object("foxglove.SceneEntity", {{"timestamp", time()},
                                                      {"frame_id", string()},
                                                      {"id", string()},
                                                      {"lifetime", object("duration", {{"sec", number()}, {"nsec", integer()}})},
                                                      {"frame_locked", boolean()},
                                                      {"metadata", array_of(object("foxglove.KeyValuePair", {{"key", string()}, {"value", string()}}))},
                                                      {"arrows", array_of(arrow)},
                                                      {"cubes", array_of(cube)},
                                                      {"spheres", array_of(sphere)},
                                                      {"cylinders", array_of(cylinder)},
                                                      {"lines", array_of(line)},
                                                      {"triangles", array_of(triangle)},
                                                      {"texts", array_of(text)},
                                                      {"models", array_of(model)}});
  const json deletion = object("foxglove.SceneEntityDeletion",
                               {{"timestamp", time()}, {"type", {{"type", "integer"}, {"minimum", 0}, {"maximum", 1}}}, {"id", string()}});
  return object("foxglove.SceneUpdate", {{"deletions", array_of(deletion)}, {"entities", array_of(entity)}});
}

}  // namespace

std::string_view grid() {
  static const std::string s = grid_schema().dump();
  return s;
}

std::string_view scene_update() {
  static const std::string s = scene_update_schema().dump();
  return s;
}

std::string_view pose_in_frame() {
  static const std::string s = object("foxglove.PoseInFrame", {{"timestamp", time()}, {"frame_id", string()}, {"pose", pose()}}).dump();
  return s;
}

std::string_view poses_in_frame() {
  static const std::string s =
      object("foxglove.PosesInFrame", {{"timestamp", time()}, {"frame_id", string()}, {"poses", array_of(pose())}}).dump();
  return s;
}

std::string_view web_state() {
  static const std::string s =
      json{{"title", "cairn.WebState"},
           {"type", "object"},
           {"description", "The Cairn web view's state: robots, landmarks, commands (docs/web-view.md)"},
           {"properties", {{"type", string()}, {"robots", {{"type", "array"}}}, {"landmarks", {{"type", "array"}}}}}}
          .dump();
  return s;
}

}  // namespace cairn::base::foxglove_schema
