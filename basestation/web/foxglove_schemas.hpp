// JSON Schemas (schema encoding "jsonschema") of the Foxglove well-known messages the base
// sends, written from Foxglove's published message reference (docs.foxglove.dev, "message
// schemas"), only the fields Cairn fills. Foxglove recognises a channel by its schema name
// (foxglove.Grid, ...); the schema tells it the field types (bytes: base64 strings).
#pragma once

#include <string_view>

namespace cairn::base::foxglove_schema {

std::string_view grid();            // foxglove.Grid
std::string_view scene_update();    // foxglove.SceneUpdate
std::string_view pose_in_frame();   // foxglove.PoseInFrame
std::string_view poses_in_frame();  // foxglove.PosesInFrame
std::string_view web_state();       // cairn.WebState: the web view's state JSON (docs/web-view.md)

}  // namespace cairn::base::foxglove_schema
