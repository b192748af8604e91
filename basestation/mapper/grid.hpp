// The central mapper's grid types: common/occupancy_grid.hpp's, under the mapper's
// namespace (the robots' frontier bids read the same types without the base station).
#pragma once

#include "common/occupancy_grid.hpp"

namespace cairn::mapper {

using cairn::Cell;
using cairn::ClassGrid;
using cairn::GridGeometry;

}  // namespace cairn::mapper
