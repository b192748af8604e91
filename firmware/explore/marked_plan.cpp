#include "firmware/explore/marked_plan.hpp"

namespace cairn::explore {

MarkedPlan plan_with_marks(GridPlanner& planner, const BlockMarks& marks, const ClassGrid& map, ClassGrid* scratch,
                           Vec2 start, Vec2 goal, Nanos now, std::vector<Vec2>* path) {
  MarkedPlan out;
  scratch->geometry = map.geometry;
  scratch->cells.assign(map.cells.begin(), map.cells.end());
  const std::size_t barriers = marks.stamp(scratch, now);
  out.status = planner.plan(scratch->geometry, scratch->cells.data(), start, goal, path);
  if (out.status == PlanStatus::kOk || barriers == 0) return out;
  // Closed by keep right alone, or a dead end? Plan again without the barriers.
  scratch->cells.assign(map.cells.begin(), map.cells.end());
  (void)marks.stamp(scratch, now, /*barriers=*/false);
  out.yielding = planner.plan(scratch->geometry, scratch->cells.data(), start, goal, path) == PlanStatus::kOk;
  if (out.yielding) out.replan_at = marks.next_barrier_end(now);
  return out;
}

}  // namespace cairn::explore
