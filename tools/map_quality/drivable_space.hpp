// The free space a disc-shaped robot can sweep from its start (docs/mapper.md, "Map
// quality"). The reachable free space counts every cell a point could reach; in a world
// whose gaps are narrower than the robot, much of it is only ever seen from afar, and an
// explorer that has mapped all it can drive to stops short of it. Coverage of the space
// the robot's body can sweep says how much of what it could have reached it mapped.
#pragma once

#include <cstdint>
#include <vector>

#include "common/occupancy_grid.hpp"
#include "common/se2.hpp"
#include "hil/world/world.hpp"

namespace cairn::tools {

/// Where a disc of radius_m can be, computed on a raster finer than `map` (at most 5 cm,
/// an integer fraction of its cells) with the world's exact geometry: the disc's centre
/// goes, 4-connected, from `start` (always allowed, like a robot already standing there)
/// through points at least radius_m from every wall and circle (robots excluded); a map
/// cell is drivable when its centre lies within radius_m of such a point. One flag per
/// cell of `map` (1: drivable); the caller intersects it with the free space.
std::vector<std::uint8_t> drivable_space(const hil::World& world, const GridGeometry& map, const Vec2& start,
                                         double radius_m);

}  // namespace cairn::tools
