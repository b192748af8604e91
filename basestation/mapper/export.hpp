// The central map's exports (docs/mapper.md, "Export formats"):
//  - PGM + YAML exactly as ROS map_server loads them and map_saver writes them
//    (trinary: obstacle 0, clear 254, unknown 205; rows from the top (max y) down;
//    origin = lower-left corner of the lower-left pixel; negate 0; occupied_thresh 0.65;
//    free_thresh 0.196 — the thresholds that decode those three values back into the
//    three classes, whatever p_o / p_c classified them);
//  - a PNG (libpng) of the map with every robot's trajectory and every landmark with
//    its 3σ ellipse;
//  - the landmark map as JSON.
// Every writer throws std::runtime_error naming the file on an I/O error.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "basestation/mapper/grid.hpp"
#include "common/messages.hpp"

namespace cairn::mapper {

/// map_saver's pixel values (trinary mode).
constexpr std::uint8_t kPgmObstacle = 0, kPgmClear = 254, kPgmUnknown = 205;
constexpr double kYamlOccupiedThresh = 0.65, kYamlFreeThresh = 0.196;

/// Writes `stem`.pgm and `stem`.yaml; the YAML's `image` is the PGM's file name
/// (map_server resolves it relative to the YAML's folder).
void write_map_server(const ClassGrid& map, const std::string& stem);

struct Trajectory {
  std::uint16_t robot = 0;
  std::vector<Vec2> points;  // global frame, in time order
};

/// A rectangle outlined in the PNG (global frame, m), e.g. an unreachable frontier.
struct MarkedBox {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  std::array<std::uint8_t, 3> rgb{};
};
/// Unreachable frontiers' outlines: too narrow for the robot orange, disconnected cyan.
inline constexpr std::array<std::uint8_t, 3> kTooNarrowRgb{{255, 140, 0}}, kDisconnectedRgb{{0, 170, 220}};

struct PngOptions {
  int pixels_per_cell = 4;
  double nsigma = 3.0;  // landmark ellipses
  std::vector<MarkedBox> boxes;  // outlined one pixel outside the rectangle, over everything else
};

/// The map (obstacle black, clear white, unknown grey), trajectories (one colour per
/// robot, start marked by a square), landmarks (a cross and the nsigma ellipse), and
/// options.boxes outlined.
void write_png(const ClassGrid& map, const std::vector<Trajectory>& trajectories, const std::vector<msg::Landmark>& landmarks,
               const std::string& path, const PngOptions& options = {});
/// The same image as PNG bytes in memory (the web view sends the bare map this way);
/// throws std::runtime_error for an empty map or an encoder failure.
std::vector<std::uint8_t> render_png(const ClassGrid& map, const std::vector<Trajectory>& trajectories,
                                     const std::vector<msg::Landmark>& landmarks, const PngOptions& options = {});

/// {"frame": "global", "count": N, "landmarks": [{"id", "x", "y", "cov": [xx, xy, yx, yy],
///  "ellipse_3sigma": {"major_m", "minor_m", "angle_rad"}}]}.
void write_landmarks_json(const std::vector<msg::Landmark>& landmarks, const std::string& path);
/// Reads what write_landmarks_json wrote (id, x, y, cov); throws std::runtime_error naming
/// the file and the problem.
std::vector<msg::Landmark> read_landmarks_json(const std::string& path);
/// The same from text; `name` prefixes the error (the fuzz target's entry).
std::vector<msg::Landmark> parse_landmarks_json(std::string_view text, const std::string& name);

/// One robot's body pose at a time of its clock (the robots' and the bench's clocks are
/// CLOCK_MONOTONIC on one machine).
struct TrajectorySample {
  std::uint16_t robot = 0;
  Nanos stamp = 0;
  Pose2 pose;
};
/// CSV, header `robot,t_ns,x,y,theta`: the trajectory the base's map was built from
/// (Mapper::body_trajectory of every robot), for scoring against a bench's ground truth.
void write_trajectories_csv(const std::vector<TrajectorySample>& samples, const std::string& path);
/// Reads what write_trajectories_csv wrote; throws std::runtime_error naming the file, the
/// line and the problem (a missing field, a non-number, a non-finite pose, a robot id
/// outside 1..65535).
std::vector<TrajectorySample> read_trajectories_csv(const std::string& path);
std::vector<TrajectorySample> parse_trajectories_csv(std::string_view text, const std::string& name);

/// Reads a map_server map (YAML + the PGM it names, relative to the YAML's folder) the
/// way map_server's loader does: occ = (255 - v) / 255 (v / 255 with negate), occ >
/// occupied_thresh -> obstacle, occ < free_thresh -> clear, else unknown; the image's
/// bottom row is the map's row 0. Binary PGM (P5, maxval 255) only; origin yaw must be 0.
/// Throws std::runtime_error naming the file and the problem.
ClassGrid read_map_server(const std::string& yaml_path);

/// Semi-axes (major >= minor) and the major axis' angle of the nsigma ellipse of a 2x2
/// covariance (a non-finite or non-positive-semidefinite covariance gives zeros).
struct Ellipse {
  double major = 0, minor = 0, angle = 0;
};
Ellipse covariance_ellipse(const msg::Cov2& cov, double nsigma);

}  // namespace cairn::mapper
