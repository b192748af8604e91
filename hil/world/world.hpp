// The HIL world: static 2D geometry (wall segments, circles; retroreflective poles are the
// point landmarks), robots as circles carrying a reflective marker, and exact ray casting
// against all of it. Loaded from a documented text format (docs/hil.md):
//
//   # comment
//   bounds  XMIN YMIN XMAX YMAX          optional; used by the random filler and the GUI
//   wall    X1 Y1 X2 Y2                  a segment
//   box     X Y W H                      four walls of an axis-aligned rectangle (X,Y = corner)
//   circle  X Y R                        a round obstacle
//   pole    X Y R                        a retroreflective pole (a landmark)
//   start   ID X Y THETA                 a robot's start pose
//   route   ID X1 Y1 X2 Y2 ...           a scripted path for robot ID (world frame; lines add up)
//   random  FRACTION SEED CELL           fill the bounds with square obstacles covering FRACTION
//
// Robot ids are integers in 1..65535 (the wire's); `random` takes an integer SEED and at
// most 10^6 cells of CELL in the bounds. tests/fuzz/files_fuzz.cpp feeds it any bytes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/se2.hpp"

namespace cairn::hil {

struct Segment {
  Vec2 a, b;
};
struct Circle {
  Vec2 c;
  double r = 0;
  bool reflective = false;  // retroreflective tape: the LMS flags the return
  int robot = 0;            // > 0: this circle is robot `robot` (moves), taped with its
                            // marker code (common/robot_marker.hpp)
  double heading = 0;       // a robot's heading: where its marker code starts
};

struct RayHit {
  double range = 0;        // m; max_range when nothing was hit
  bool hit = false;
  bool reflective = false;
  int robot = 0;           // robot id hit, or 0
};

class World {
 public:
  /// Parses a world file; throws std::runtime_error naming file and line on an error.
  static World load(const std::string& path);
  static World parse(const std::string& text, const std::string& name);

  /// Exact first intersection of the ray from `origin` in direction `angle` (rad).
  RayHit cast(const Vec2& origin, double angle, double max_range, int ignore_robot = 0) const;

  /// Places (or moves) robot `id`, a circle of radius `r` at `pose` wearing its coded
  /// marker (turned with the pose's heading).
  void set_robot(int id, const Pose2& pose, double radius);
  void remove_robot(int id);
  /// True if a disc at `p` of radius `r` touches any obstacle (for the simulated robot).
  bool collides(const Vec2& p, double r, int ignore_robot = 0) const;

  const std::vector<Segment>& segments() const { return segments_; }
  const std::vector<Circle>& circles() const { return circles_; }
  std::vector<Vec2> poles() const;
  std::optional<Pose2> start(int id) const;
  /// Robot `id`'s scripted waypoints (world frame), empty when it has none.
  std::vector<Vec2> route(int id) const;
  struct Bounds {
    double xmin = -10, ymin = -10, xmax = 10, ymax = 10;
  };
  const Bounds& bounds() const { return bounds_; }
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  Bounds bounds_;
  std::vector<Segment> segments_;
  std::vector<Circle> circles_;
  std::vector<std::pair<int, Pose2>> starts_;
  std::vector<std::pair<int, std::vector<Vec2>>> routes_;
};

}  // namespace cairn::hil
