#include "basestation/explore/igr_overlap.hpp"

#include <algorithm>
#include <vector>

namespace cairn::explore {

double area(const Rect& r) { return std::max(0.0, r.max_x - r.min_x) * std::max(0.0, r.max_y - r.min_y); }

bool contains(const Rect& r, double x, double y) { return x >= r.min_x && x <= r.max_x && y >= r.min_y && y <= r.max_y; }

double union_area(std::span<const Rect> rects) {
  std::vector<double> xs, ys;
  for (const Rect& r : rects) {
    if (area(r) <= 0) continue;
    xs.insert(xs.end(), {r.min_x, r.max_x});
    ys.insert(ys.end(), {r.min_y, r.max_y});
  }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::sort(ys.begin(), ys.end());
  ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
  double total = 0;
  for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
    for (std::size_t j = 0; j + 1 < ys.size(); ++j) {
      const double cx = 0.5 * (xs[i] + xs[i + 1]), cy = 0.5 * (ys[j] + ys[j + 1]);
      const bool covered = std::any_of(rects.begin(), rects.end(), [&](const Rect& r) { return area(r) > 0 && contains(r, cx, cy); });
      if (covered) total += (xs[i + 1] - xs[i]) * (ys[j + 1] - ys[j]);
    }
  }
  return total;
}

double overlap_fraction(const Rect& igr, std::span<const Rect> assigned) {
  const double a = area(igr);
  if (a <= 0) {
    const double cx = 0.5 * (igr.min_x + igr.max_x), cy = 0.5 * (igr.min_y + igr.max_y);
    return std::any_of(assigned.begin(), assigned.end(), [&](const Rect& r) { return contains(r, cx, cy); }) ? 1.0 : 0.0;
  }
  std::vector<Rect> clipped;
  clipped.reserve(assigned.size());
  for (const Rect& r : assigned) {
    const Rect c{std::max(igr.min_x, r.min_x), std::max(igr.min_y, r.min_y), std::min(igr.max_x, r.max_x), std::min(igr.max_y, r.max_y)};
    if (c.max_x > c.min_x && c.max_y > c.min_y) clipped.push_back(c);
  }
  return std::min(1.0, union_area(clipped) / a);
}

}  // namespace cairn::explore
