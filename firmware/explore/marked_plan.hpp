// One plan on a classified map with what has held the robot stamped in (BlockMarks), as
// cairn-robot's RobotExplorer and cairn-sim's exploration driver both make it: the marks
// go into `scratch` (a copy of `map`; within its reserve, no allocation), and a plan that
// fails only because of keep-right barriers is a yield, told apart from a dead end by
// planning again without them.
#pragma once

#include <vector>

#include "firmware/explore/block_marks.hpp"
#include "firmware/explore/grid_planner.hpp"

namespace cairn::explore {

struct MarkedPlan {
  PlanStatus status = PlanStatus::kBadMap;  // with the barriers
  bool yielding = false;                    // failed with them, a path without: stand until
  Nanos replan_at = -1;                     // the first barrier ends (-1: not yielding)
};

MarkedPlan plan_with_marks(GridPlanner& planner, const BlockMarks& marks, const ClassGrid& map, ClassGrid* scratch,
                           Vec2 start, Vec2 goal, Nanos now, std::vector<Vec2>* path);

}  // namespace cairn::explore
