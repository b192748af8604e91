// cairn-map-quality: compares a map (map_server PGM + YAML, as cairn-base exports it)
// with a HIL world file's ground truth rasterised on the map's grid (docs/mapper.md).
//
//   cairn-map-quality --map map.yaml --world hil/worlds/office.world [--start X Y] [--json]
//                     [--robot-radius R]   also the coverage of the space a robot of radius R sweeps
//                     [--truth STEM]   also write the rasterised truth as STEM.pgm/.yaml
//                     [--landmarks landmarks.json]   also score the mapped landmarks against the poles
//                     [--trajectories trajectories.csv --ground-truth truth.txt]   and the robots' poses
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <iostream>
#include <optional>

#include "basestation/mapper/export.hpp"
#include "tools/map_quality/map_quality.hpp"
#include "tools/map_quality/pose_quality.hpp"

int main(int argc, char** argv) {
  CLI::App app{"cairn-map-quality: a map against a HIL world's ground truth (coverage, agreement, false cells, wall offset)"};
  std::string map_path, world_path, truth_stem, landmarks_path, trajectories_path, ground_truth_path;
  std::vector<double> start;
  bool json = false;
  double robot_radius = 0;
  app.add_option("--map", map_path, "map_server YAML (its PGM next to it)")->required();
  app.add_option("--world", world_path, "HIL world file (hil/worlds/*.world)")->required();
  app.add_option("--start", start, "flood-fill start X Y (m, world frame); default: robot 1's start")->expected(2);
  app.add_flag("--json", json, "print JSON instead of text");
  app.add_option("--robot-radius", robot_radius,
                 "also report the drivable coverage: of the free space a disc of this radius (m) sweeps from the start "
                 "(cairn-sim's robots: 0.3)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--truth", truth_stem, "also write the rasterised truth as STEM.pgm + STEM.yaml");
  app.add_option("--landmarks", landmarks_path,
                 "also score the base's landmarks.json against the world's poles (nearest within 1 m, one to one)");
  auto* traj = app.add_option("--trajectories", trajectories_path,
                               "also score the robots' poses: the base's trajectories.csv (exported beside the map)");
  auto* gt = app.add_option("--ground-truth", ground_truth_path, "the bench's truth file (cairn-hil robots --truth FILE)");
  traj->needs(gt);
  gt->needs(traj);
  CLI11_PARSE(app, argc, argv);
  try {
    const cairn::mapper::ClassGrid map = cairn::mapper::read_map_server(map_path);
    const cairn::hil::World world = cairn::hil::World::load(world_path);
    const cairn::Vec2 s = start.size() == 2 ? cairn::Vec2(start[0], start[1]) : cairn::tools::default_start(world);
    const cairn::tools::MapQuality q =
        cairn::tools::evaluate(map, cairn::tools::make_reference(world, map.geometry, s, robot_radius), world);
    if (!truth_stem.empty())
      cairn::mapper::write_map_server(cairn::tools::truth_as_map(cairn::tools::rasterise(world, map.geometry, s)), truth_stem);
    std::optional<cairn::tools::LandmarkQuality> l;
    if (!landmarks_path.empty()) {
      l = cairn::tools::evaluate_landmarks(cairn::mapper::read_landmarks_json(landmarks_path), world.poles());
    }
    std::optional<cairn::tools::PoseQuality> p;
    if (!trajectories_path.empty()) {
      p = cairn::tools::evaluate_poses(cairn::mapper::read_trajectories_csv(trajectories_path),
                                       cairn::tools::read_ground_truth(ground_truth_path));
    }
    if (json) {
      std::cout << cairn::tools::to_json(q, l ? &*l : nullptr, p ? &*p : nullptr) << "\n";
    } else {
      std::cout << cairn::tools::to_text(q) << (l ? cairn::tools::to_text(*l) : "") << (p ? cairn::tools::to_text(*p) : "");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cairn-map-quality: %s\n", e.what());
    return 2;
  }
  return 0;
}
