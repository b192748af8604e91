// Time per frontier bid (FrontierBidder::compute) on two synthetic, deterministic,
// half-explored office maps at 0.15 m: 25 × 20 m (the seed's world A size) and 62 × 43 m
// (the seed's building). Baseline in the same run: one plain 4-connected BFS over the
// known clear cells from the robot (the cheapest flood fill over the same map).
// The exit status is the verdict: 1 when the building's median exceeds --max-ms.
//   build/ci/tests/bench/cairn-bench-frontier-bids [--reps 30] [--range 4] [--max-ms 50] [--json]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware/explore/frontier_bids.hpp"

using namespace cairn;
using namespace cairn::explore;

namespace {

constexpr double kRes = 0.15;

struct Map {
  GridGeometry g;
  std::vector<Cell> cells;
  Pose2 robot;
};

// Ground truth: an office with a spine corridor on the left (x 0..2.5 m), horizontal
// corridors 2.5 m wide at the given heights, rooms `room_w` wide on both sides of each
// with a 1 m door, and a wall halfway between two corridors.
std::vector<Cell> office(const GridGeometry& g, const std::vector<double>& corridor_y, double room_w) {
  std::vector<Cell> t(g.cells(), Cell::kClear);
  auto rect = [&](double x0, double y0, double x1, double y1, Cell v) {
    int i0 = 0, j0 = 0, i1 = 0, j1 = 0;
    g.cell_of(std::max(x0, g.origin_x), std::max(y0, g.origin_y), &i0, &j0);
    g.cell_of(std::min(x1, g.xmax() - 1e-6), std::min(y1, g.ymax() - 1e-6), &i1, &j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) t[g.index(i, j)] = v;
  };
  const double w = g.xmax(), h = g.ymax(), th = 0.14;  // one cell thick
  rect(0, 0, w, th, Cell::kObstacle);
  rect(0, h - th, w, h, Cell::kObstacle);
  rect(0, 0, th, h, Cell::kObstacle);
  rect(w - th, 0, w, h, Cell::kObstacle);
  rect(2.5, 0, 2.5 + th, h, Cell::kObstacle);  // the spine's wall
  for (std::size_t k = 0; k < corridor_y.size(); ++k) {
    const double y0 = corridor_y[k], y1 = y0 + 2.5;
    rect(2.5, y0, 2.5 + th, y1, Cell::kClear);  // the corridor opens onto the spine
    rect(2.5, y0 - th, w, y0, Cell::kObstacle);
    rect(2.5, y1, w, y1 + th, Cell::kObstacle);
    for (double x = 2.5 + room_w; x < w; x += room_w) {  // room walls on both sides
      rect(x, y0 - 10, x + th, y0, Cell::kObstacle);
      rect(x, y1, x + th, y1 + 10, Cell::kObstacle);
    }
    for (double x = 2.5 + room_w / 2 - 0.5; x + 1 < w; x += room_w) {  // doors
      rect(x, y0 - th, x + 1.0, y0, Cell::kClear);
      rect(x, y1, x + 1.0, y1 + th, Cell::kClear);
    }
    if (k + 1 < corridor_y.size()) rect(2.5, (y1 + corridor_y[k + 1]) / 2, w, (y1 + corridor_y[k + 1]) / 2 + th, Cell::kObstacle);
  }
  return t;
}

// Half explored: the free cells within the median geodesic distance of the robot are
// known clear, the walls touching them known obstacles, the rest unknown.
Map half_explored(double width_m, double height_m, const std::vector<double>& corridor_y, double room_w) {
  Map m;
  m.g = {kRes, 0, 0, static_cast<int>(std::lround(width_m / kRes)), static_cast<int>(std::lround(height_m / kRes))};
  const std::vector<Cell> truth = office(m.g, corridor_y, room_w);
  m.robot = {1.2, corridor_y.front() + 1.2, 0};
  int ri = 0, rj = 0;
  m.g.cell_of(m.robot.x, m.robot.y, &ri, &rj);
  std::vector<int> dist(m.g.cells(), -1);
  std::deque<std::size_t> q{m.g.index(ri, rj)};
  dist[q.front()] = 0;
  std::vector<int> reached;
  while (!q.empty()) {
    const std::size_t c = q.front();
    q.pop_front();
    reached.push_back(dist[c]);
    const int i = static_cast<int>(c % static_cast<std::size_t>(m.g.width)), j = static_cast<int>(c / static_cast<std::size_t>(m.g.width));
    for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (!m.g.contains(i + di, j + dj)) continue;
      const std::size_t n = m.g.index(i + di, j + dj);
      if (truth[n] != Cell::kClear || dist[n] >= 0) continue;
      dist[n] = dist[c] + 1;
      q.push_back(n);
    }
  }
  std::nth_element(reached.begin(), reached.begin() + static_cast<std::ptrdiff_t>(reached.size() / 2), reached.end());
  const int limit = reached[reached.size() / 2];
  m.cells.assign(m.g.cells(), Cell::kUnknown);
  for (int j = 0; j < m.g.height; ++j)
    for (int i = 0; i < m.g.width; ++i) {
      const std::size_t c = m.g.index(i, j);
      if (dist[c] < 0 || dist[c] > limit) continue;
      m.cells[c] = Cell::kClear;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
          if (m.g.contains(i + di, j + dj) && truth[m.g.index(i + di, j + dj)] == Cell::kObstacle)
            m.cells[m.g.index(i + di, j + dj)] = Cell::kObstacle;
    }
  return m;
}

// The baseline: a plain BFS over known clear cells, buffers preallocated.
std::size_t bfs(const Map& m, std::vector<std::uint32_t>* queue, std::vector<std::uint8_t>* seen) {
  std::fill(seen->begin(), seen->end(), 0);
  int ri = 0, rj = 0;
  m.g.cell_of(m.robot.x, m.robot.y, &ri, &rj);
  std::size_t head = 0, tail = 0;
  (*queue)[tail++] = static_cast<std::uint32_t>(m.g.index(ri, rj));
  (*seen)[m.g.index(ri, rj)] = 1;
  const auto w = static_cast<std::uint32_t>(m.g.width);
  while (head < tail) {
    const std::uint32_t c = (*queue)[head++];
    const int i = static_cast<int>(c % w), j = static_cast<int>(c / w);
    for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (!m.g.contains(i + di, j + dj)) continue;
      const std::size_t n = m.g.index(i + di, j + dj);
      if (m.cells[n] != Cell::kClear || (*seen)[n]) continue;
      (*seen)[n] = 1;
      (*queue)[tail++] = static_cast<std::uint32_t>(n);
    }
  }
  return tail;
}

struct Figures {
  std::string name;
  int width = 0, height = 0;
  std::size_t known = 0;
  double median_ms = 0, max_ms = 0, baseline_ms = 0;
  BidStats stats;
  std::size_t items = 0;
  double best_gain = 0, best_cost = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Figures run(const std::string& name, const Map& m, double range, int reps) {
  FrontierBidderConfig cfg;
  cfg.max_cells = m.g.cells();
  cfg.sensor_range_m = range;
  FrontierBidder bidder(cfg);
  msg::Bid bid;
  std::vector<std::uint32_t> queue(m.g.cells());
  std::vector<std::uint8_t> seen(m.g.cells());
  std::vector<double> bid_ms, bfs_ms;
  using Clock = std::chrono::steady_clock;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = Clock::now();
    const BidStatus s = bidder.compute(m.g, m.cells.data(), m.robot, &bid);
    const auto t1 = Clock::now();
    if (s != BidStatus::kOk) throw std::runtime_error(name + ": " + to_string(s));
    bfs(m, &queue, &seen);
    const auto t2 = Clock::now();
    bid_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    bfs_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  Figures f;
  f.name = name;
  f.width = m.g.width;
  f.height = m.g.height;
  f.known = static_cast<std::size_t>(std::count_if(m.cells.begin(), m.cells.end(), [](Cell c) { return c != Cell::kUnknown; }));
  f.median_ms = median(bid_ms);
  f.max_ms = *std::max_element(bid_ms.begin(), bid_ms.end());
  f.baseline_ms = median(bfs_ms);
  f.stats = bidder.stats();
  f.items = bid.n_items;
  f.best_gain = bid.items[0].gain;
  f.best_cost = bid.items[0].cost;
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time per frontier bid on synthetic half-explored office maps"};
  int reps = 30;
  double range = 4.0, max_ms = 0;
  bool json = false;
  app.add_option("--reps", reps, "bids per map")->check(CLI::PositiveNumber);
  app.add_option("--range", range, "sensor_range_m")->check(CLI::PositiveNumber);
  app.add_option("--max-ms", max_ms, "fail when the 62 x 43 m median exceeds this (0: no bound)");
  app.add_flag("--json", json, "one JSON object on stdout (the table goes to stderr)");
  CLI11_PARSE(app, argc, argv);

  const std::vector<Figures> figures = {
      run("office_25x20", half_explored(25, 20, {9.0}, 5.0), range, reps),
      run("building_62x43", half_explored(62, 43, {10.0, 30.0}, 6.0), range, reps)};
  FILE* table = json ? stderr : stdout;
  std::fprintf(table, "%-15s %9s %7s %9s %9s %9s %9s %9s %11s %6s\n", "map", "cells", "known", "bid_ms", "max_ms",
               "bfs_ms", "frontier", "unreach", "candidates", "items");
  nlohmann::json out = {{"bench", "frontier_bids"}, {"resolution_m", kRes}, {"sensor_range_m", range}, {"reps", reps}};
  for (const Figures& f : figures) {
    std::fprintf(table, "%-15s %9d %7zu %9.3f %9.3f %9.3f %9zu %9zu %11zu %6zu\n", f.name.c_str(), f.width * f.height,
                 f.known, f.median_ms, f.max_ms, f.baseline_ms, f.stats.frontier_cells,
                 f.stats.unreachable_frontier_cells, f.stats.candidates, f.items);
    out[f.name] = {{"width", f.width},
                   {"height", f.height},
                   {"known_cells", f.known},
                   {"bid_ms_median", f.median_ms},
                   {"bid_ms_max", f.max_ms},
                   {"baseline_bfs_ms_median", f.baseline_ms},
                   {"frontier_cells", f.stats.frontier_cells},
                   {"unreachable_frontier_cells", f.stats.unreachable_frontier_cells},
                   {"candidates", f.stats.candidates},
                   {"gain_cells_visited", f.stats.gain_cells_visited},
                   {"items", f.items},
                   {"best_gain_cells", f.best_gain},
                   {"best_cost_m", f.best_cost}};
  }
  const bool over = max_ms > 0 && figures.back().median_ms > max_ms;
  out["max_ms"] = max_ms;
  out["pass"] = !over;
  if (json) std::printf("%s\n", out.dump(2).c_str());
  if (over) std::fprintf(stderr, "FAIL: 62 x 43 m bid median %.3f ms > %.3f ms\n", figures.back().median_ms, max_ms);
  return over ? 1 : 0;
}
