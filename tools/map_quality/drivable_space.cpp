#include "tools/map_quality/drivable_space.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "tools/map_quality/map_quality.hpp"

namespace cairn::tools {

namespace {

constexpr double kFineMaxM = 0.05;

// Calls on(i, j) for every cell of g within r_cells (centre to centre) of (ci, cj).
template <typename F>
void for_disc(const GridGeometry& g, int ci, int cj, double r_cells, F&& on) {
  const int n = static_cast<int>(std::floor(r_cells));
  const double r2 = r_cells * r_cells + 1e-9;
  for (int dj = -n; dj <= n; ++dj)
    for (int di = -n; di <= n; ++di)
      if (di * di + dj * dj <= r2 && g.contains(ci + di, cj + dj)) on(ci + di, cj + dj);
}

}  // namespace

std::vector<std::uint8_t> drivable_space(const hil::World& world, const GridGeometry& map, const Vec2& start,
                                         double radius_m) {
  if (!(std::isfinite(radius_m) && radius_m > 0))
    throw std::invalid_argument("drivable space: robot radius must be finite and > 0 (got " + std::to_string(radius_m) + ")");
  // Odd: a map cell's centre is then a fine cell's centre, not a corner between four.
  int k = std::max(1, static_cast<int>(std::ceil(map.resolution / kFineMaxM - 1e-9)));
  if (k % 2 == 0) ++k;
  if (static_cast<double>(map.width) * k * static_cast<double>(map.height) * k > 2e8)
    throw std::invalid_argument("drivable space: the map is too large for a raster of at most 5 cm");
  GridGeometry fine = map;
  fine.resolution = map.resolution / k;
  fine.width = map.width * k;
  fine.height = map.height * k;
  const std::size_t n = fine.cells();

  // Clearance: the exact distance is needed only near a wall, i.e. within radius_m plus a
  // fine cell's half-diagonal of a fine cell a wall touches; elsewhere the disc fits.
  const TruthGrid walls = rasterise(world, fine, start);
  std::vector<std::uint8_t> near(n, 0);
  const double near_cells = radius_m / fine.resolution + 1.5;
  for (int j = 0; j < fine.height; ++j)
    for (int i = 0; i < fine.width; ++i)
      if (walls.at(i, j) == Truth::kWall) for_disc(fine, i, j, near_cells, [&](int a, int b) { near[fine.index(a, b)] = 1; });

  enum : std::uint8_t { kUnseen = 0, kFits = 1, kTooClose = 2 };
  std::vector<std::uint8_t> fit(n, kUnseen);
  auto fits = [&](int i, int j) {
    std::uint8_t& f = fit[fine.index(i, j)];
    if (f == kUnseen) f = (!near[fine.index(i, j)] || distance_to_wall(world, fine.center(i, j)) >= radius_m) ? kFits : kTooClose;
    return f == kFits;
  };
  int si = 0, sj = 0;
  if (!fine.cell_of(start.x(), start.y(), &si, &sj))
    throw std::invalid_argument("drivable space: start point (" + std::to_string(start.x()) + ", " +
                                std::to_string(start.y()) + ") is outside the map");
  std::vector<std::uint8_t> reached(n, 0);
  std::vector<std::uint32_t> queue;
  queue.reserve(n);
  reached[fine.index(si, sj)] = 1;
  queue.push_back(static_cast<std::uint32_t>(fine.index(si, sj)));
  const int di4[4] = {1, -1, 0, 0}, dj4[4] = {0, 0, 1, -1};
  const auto w = static_cast<std::uint32_t>(fine.width);
  std::vector<std::uint32_t> edge;  // reached cells with an unreached 4-neighbour
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int i = static_cast<int>(queue[head] % w), j = static_cast<int>(queue[head] / w);
    bool on_edge = false;
    for (int d = 0; d < 4; ++d) {
      const int a = i + di4[d], b = j + dj4[d];
      if (!fine.contains(a, b)) continue;
      const std::size_t nb = fine.index(a, b);
      if (reached[nb]) continue;
      if (!fits(a, b)) {
        on_edge = true;
        continue;
      }
      reached[nb] = 1;
      queue.push_back(static_cast<std::uint32_t>(nb));
    }
    if (on_edge) edge.push_back(queue[head]);
  }
  // Swept: the reached centres and every point within radius_m of one. For a point p within
  // radius_m of a reached centre c but not itself reached, the lattice disc about p is
  // 4-connected and holds c: a 4-path in it from c meets an unreached cell, and the reached
  // cell before that is an edge cell within radius_m of p. The edge cells' discs suffice.
  std::vector<std::uint8_t> swept = reached;
  const double r_cells = radius_m / fine.resolution;
  for (const std::uint32_t c : edge)
    for_disc(fine, static_cast<int>(c % w), static_cast<int>(c / w), r_cells, [&](int a, int b) { swept[fine.index(a, b)] = 1; });

  std::vector<std::uint8_t> out(map.cells(), 0);
  for (int j = 0; j < map.height; ++j)
    for (int i = 0; i < map.width; ++i) {
      int fi = 0, fj = 0;
      const Vec2 c = map.center(i, j);
      if (fine.cell_of(c.x(), c.y(), &fi, &fj)) out[map.index(i, j)] = swept[fine.index(fi, fj)];
    }
  return out;
}

}  // namespace cairn::tools
