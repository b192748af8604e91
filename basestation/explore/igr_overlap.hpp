// The executive's discount (seed §4): how much of one frontier's information-gain region
// (IGR) is already covered by the IGRs of the tasks assigned so far, all approximated by
// their axis-aligned bounding rectangles (global frame, metres).
#pragma once

#include <span>

#include "common/messages.hpp"

namespace cairn::explore {

struct Rect {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

inline Rect igr_of(const msg::BidItem& item) { return {item.igr_min_x, item.igr_min_y, item.igr_max_x, item.igr_max_y}; }

double area(const Rect& r);
bool contains(const Rect& r, double x, double y);  // closed rectangle

/// Area of the union of rectangles (exact, coordinate compression; O(n^3), n is the fleet).
double union_area(std::span<const Rect> rects);

/// d_j = Area(IGR_j ∩ (∪_i IGR_i)) / Area(IGR_j): the union, so two assigned regions that
/// overlap each other are not counted twice and d_j never exceeds 1. A degenerate IGR_j
/// (zero area: a line or a point) counts as covered (1) if its centre lies in any assigned
/// rectangle, else 0.
double overlap_fraction(const Rect& igr, std::span<const Rect> assigned);

}  // namespace cairn::explore
