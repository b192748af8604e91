// FrontierBidder on hand-made maps whose answers are derived by hand or by a slow
// reference written independently here: frontier thinning, path cost, information gain
// and its rectangle, unreachable frontiers behind narrow gaps, walls stopping both floods,
// ranking and the item cap, config and map refusals, and no allocation per bid.
#include "firmware/explore/frontier_bids.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#ifndef CAIRN_SANITIZED
#include "tests/support/alloc_counter.hpp"
#endif

namespace cairn::explore {
namespace {

constexpr double kRes = 0.15;

struct Map {
  GridGeometry g;
  std::vector<Cell> c;

  Map(int w, int h, double ox = 0, double oy = 0) : g{kRes, ox, oy, w, h}, c(g.cells(), Cell::kUnknown) {}
  void fill(int i0, int j0, int i1, int j1, Cell v) {  // inclusive
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) c[g.index(i, j)] = v;
  }
  Cell at(int i, int j) const { return c[g.index(i, j)]; }
  Pose2 pose_at(int i, int j) const { return {g.center(i, j).x(), g.center(i, j).y(), 0}; }
};

FrontierBidderConfig config(double radius, double range) {
  FrontierBidderConfig c;
  c.max_cells = 10000;
  c.robot_radius_m = radius;
  c.sensor_range_m = range;
  return c;
}

struct Region {
  std::size_t count = 0;
  int i0 = 1 << 30, j0 = 1 << 30, i1 = -1, j1 = -1;
};

// The reference gain: grows the region by whole-map sweeps until nothing changes (no
// queue, no stamps): an unknown cell within range joins when it is a 4-neighbour of the
// frontier cell or of a cell already in.
Region reference_gain(const Map& m, int fi, int fj, double range_m) {
  const double r2 = (range_m / kRes) * (range_m / kRes) + 1e-9;
  std::vector<char> in(m.c.size(), 0);
  for (bool changed = true; changed;) {
    changed = false;
    for (int j = 0; j < m.g.height; ++j)
      for (int i = 0; i < m.g.width; ++i) {
        if (in[m.g.index(i, j)] || m.at(i, j) != Cell::kUnknown) continue;
        if ((i - fi) * (i - fi) + (j - fj) * (j - fj) > r2) continue;
        bool joins = false;
        for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int ni = i + di, nj = j + dj;
          if (!m.g.contains(ni, nj)) continue;
          joins = joins || (ni == fi && nj == fj) || in[m.g.index(ni, nj)];
        }
        if (joins) in[m.g.index(i, j)] = 1, changed = true;
      }
  }
  Region r;
  for (int j = 0; j < m.g.height; ++j)
    for (int i = 0; i < m.g.width; ++i)
      if (in[m.g.index(i, j)]) {
        ++r.count;
        r.i0 = std::min(r.i0, i), r.j0 = std::min(r.j0, j), r.i1 = std::max(r.i1, i), r.j1 = std::max(r.j1, j);
      }
  return r;
}

std::pair<int, int> cell_of(const Map& m, const msg::BidItem& item) {
  int i = -1, j = -1;
  EXPECT_TRUE(m.g.cell_of(item.x, item.y, &i, &j));
  return {i, j};
}

// A 3-cell corridor (rows 6..8) from i = 2 to i = 21, walled, opening at i = 22 into unknown.
Map corridor() {
  Map m(40, 15, 1.0, -2.0);
  m.fill(1, 5, 21, 5, Cell::kObstacle);
  m.fill(1, 9, 21, 9, Cell::kObstacle);
  m.fill(1, 5, 1, 9, Cell::kObstacle);
  m.fill(2, 6, 21, 8, Cell::kClear);
  return m;
}

TEST(FrontierBids, CorridorEndingInUnknownGivesOneThinnedFrontier) {
  const Map m = corridor();
  FrontierBidder bidder(config(0.05, 0.9));  // 0.05 m: no inflation at 0.15 m; range 6 cells
  msg::Bid bid;
  ASSERT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(3, 7), &bid), BidStatus::kOk);
  EXPECT_EQ(bidder.stats().frontier_cells, 3u);  // (21, 6..8)
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 0u);
  EXPECT_EQ(bidder.stats().candidates, 1u);  // (21, 7) first (nearest); its neighbours are 0.15 m away
  ASSERT_EQ(bid.n_items, 1);
  const msg::BidItem& item = bid.items[0];
  EXPECT_EQ(cell_of(m, item), (std::pair{21, 7}));
  EXPECT_NEAR(item.x, 1.0 + 21.5 * kRes, 1e-12);
  EXPECT_NEAR(item.y, -2.0 + 7.5 * kRes, 1e-12);
  EXPECT_NEAR(item.cost, 18 * kRes, kRes * std::sqrt(2.0));  // 18 cells along the corridor
  // By hand: unknown cells within 6 cells of (21, 7), all connected through the opening:
  // the disc beyond i = 21 (i up to 27) and, outside the walls, rows 1..4 and 10..13 from
  // i = 16 (row 4: |i - 21| <= sqrt(27)). The slow reference counts them.
  const Region ref = reference_gain(m, 21, 7, 0.9);
  EXPECT_EQ(item.gain, static_cast<double>(ref.count));
  EXPECT_EQ((std::vector{ref.i0, ref.i1, ref.j0, ref.j1}), (std::vector{16, 27, 1, 13}));
  EXPECT_NEAR(item.igr_min_x, 1.0 + 16 * kRes, 1e-9);  // to the cell edge (FMA on Arm differs in the last bits)
  EXPECT_NEAR(item.igr_max_x, 1.0 + 28 * kRes, 1e-9);  // to the cell edge (FMA on Arm differs in the last bits)
  EXPECT_NEAR(item.igr_min_y, -2.0 + 1 * kRes, 1e-9);  // to the cell edge (FMA on Arm differs in the last bits)
  EXPECT_NEAR(item.igr_max_y, -2.0 + 14 * kRes, 1e-9);  // to the cell edge (FMA on Arm differs in the last bits)
}

// Left room clear (i < 10), a wall at i = 10 with a gap of `gap` cells centred on j = 10,
// a clear pocket i = 11..15, unknown from i = 16: 20 frontier cells at i = 15.
Map wall_with_gap(int gap) {
  Map m(30, 21);
  m.fill(0, 0, 9, 20, Cell::kClear);
  m.fill(10, 0, 10, 20, Cell::kObstacle);
  m.fill(11, 0, 15, 20, Cell::kClear);
  m.fill(10, 10 - gap / 2, 10, 10 - gap / 2 + gap - 1, Cell::kClear);
  return m;
}

TEST(FrontierBids, GapNarrowerThanTheRobotIsUnreachableAndCounted) {
  FrontierBidder bidder(config(0.30, 1.5));  // needs a 0.60 m gap
  msg::Bid bid;
  const Map narrow = wall_with_gap(3);  // 0.45 m
  EXPECT_EQ(bidder.compute(narrow.g, narrow.c.data(), narrow.pose_at(4, 10), &bid), BidStatus::kNoFrontier);
  EXPECT_EQ(bid.n_items, 0);
  EXPECT_EQ(bidder.stats().frontier_cells, 21u);
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 21u);

  // Exactly 2r (0.60 m): no cell centre in it is 0.30 m from both faces (docs/explore.md).
  const Map exact = wall_with_gap(4);
  EXPECT_EQ(bidder.compute(exact.g, exact.c.data(), exact.pose_at(4, 10), &bid), BidStatus::kNoFrontier);

  const Map wide = wall_with_gap(5);  // 0.75 m
  ASSERT_EQ(bidder.compute(wide.g, wide.c.data(), wide.pose_at(4, 10), &bid), BidStatus::kOk);
  EXPECT_GE(bid.n_items, 1);
  EXPECT_EQ(bidder.stats().frontier_cells, 21u);
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 0u);
  for (std::size_t k = 0; k < bid.n_items; ++k) EXPECT_EQ(cell_of(wide, bid.items[k]).first, 15);
  // Through the gap's centre (10, 10): at least the straight 11 cells, at most with a diagonal detour.
  EXPECT_NEAR(bid.items[0].cost, 11 * kRes, kRes * std::sqrt(2.0));
}

// A closed room (i = 0..9) with a 3-cell (0.45 m) door in its wall at i = 10, rows 9..11;
// the laser has seen one cell past the door (i = 11, rows 9..11), the rest beyond is unknown.
Map room_behind_door() {
  Map m(30, 21);
  m.fill(0, 0, 9, 20, Cell::kClear);
  m.fill(10, 0, 10, 20, Cell::kObstacle);
  m.fill(10, 9, 11, 11, Cell::kClear);
  return m;
}

TEST(FrontierBids, RoomBehindANarrowDoorIsOneTooNarrowClusterAtTheDoor) {
  FrontierBidder bidder(config(0.30, 1.5));  // needs a 0.60 m gap
  const Map m = room_behind_door();
  msg::Bid bid;
  EXPECT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(4, 10), &bid), BidStatus::kNoFrontier);
  EXPECT_EQ(bid.n_items, 0);  // never bid
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 3u);  // (11, 9..11)
  ASSERT_EQ(bid.n_unreachable, 1);
  EXPECT_EQ(bid.unreachable_dropped, 0u);
  const msg::UnreachableCluster& u = bid.unreachable[0];
  EXPECT_EQ(u.kind, msg::UnreachableKind::kTooNarrow);
  EXPECT_EQ(u.cells, 3u);
  const double door_x = 10.5 * kRes, door_y = 10.5 * kRes;  // the door's centre cell
  EXPECT_LT(std::hypot(u.x - door_x, u.y - door_y), 0.3);
  EXPECT_NEAR(u.x, 11.5 * kRes, 1e-9);
  EXPECT_NEAR(u.y, 10.5 * kRes, 1e-9);
  EXPECT_NEAR(u.min_x, 11 * kRes, 1e-9);
  EXPECT_NEAR(u.max_x, 12 * kRes, 1e-9);
  EXPECT_NEAR(u.min_y, 9 * kRes, 1e-9);
  EXPECT_NEAR(u.max_y, 12 * kRes, 1e-9);

  // A robot small enough for the door bids it, and nothing is unreachable.
  FrontierBidder small(config(0.05, 1.5));
  ASSERT_EQ(small.compute(m.g, m.c.data(), m.pose_at(4, 10), &bid), BidStatus::kOk);
  EXPECT_EQ(bid.n_unreachable, 0);
  EXPECT_EQ(cell_of(m, bid.items[0]).first, 11);
}

TEST(FrontierBids, RoomSeenThroughAWindowIsDisconnected) {
  // The room's wall at i = 10 is whole; beyond it the laser saw a patch (i = 11..14,
  // rows 5..15) through a window: clear, but no known clear path leads there.
  Map m(30, 21);
  m.fill(0, 0, 9, 20, Cell::kClear);
  m.fill(10, 0, 10, 20, Cell::kObstacle);
  m.fill(11, 5, 14, 15, Cell::kClear);
  FrontierBidder bidder(config(0.30, 1.5));
  msg::Bid bid;
  EXPECT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(4, 10), &bid), BidStatus::kNoFrontier);
  EXPECT_EQ(bid.n_items, 0);
  // The patch's frontier: column 14 (11 cells) and rows 5 and 15 (i = 11..13, 3 + 3), one ring.
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 17u);
  ASSERT_EQ(bid.n_unreachable, 1);
  const msg::UnreachableCluster& u = bid.unreachable[0];
  EXPECT_EQ(u.kind, msg::UnreachableKind::kDisconnected);
  EXPECT_EQ(u.cells, 17u);
  EXPECT_NEAR(u.min_x, 11 * kRes, 1e-9);
  EXPECT_NEAR(u.max_x, 15 * kRes, 1e-9);
  EXPECT_NEAR(u.min_y, 5 * kRes, 1e-9);
  EXPECT_NEAR(u.max_y, 16 * kRes, 1e-9);
  // Even a point robot could not get there: still disconnected, not too narrow.
  FrontierBidder point(config(0.0, 1.5));
  EXPECT_EQ(point.compute(m.g, m.c.data(), m.pose_at(4, 10), &bid), BidStatus::kNoFrontier);
  ASSERT_EQ(bid.n_unreachable, 1);
  EXPECT_EQ(bid.unreachable[0].kind, msg::UnreachableKind::kDisconnected);
}

TEST(FrontierBids, MoreThanSixteenClustersKeepsTheLargestAndCountsTheRest) {
  // A closed room, and beyond its wall 20 seen patches in unknown space, none connected:
  // 17 of 2 × 2 cells (4 frontier cells each) and 3 single cells, placed so the singles
  // come first in scan order.
  Map m(60, 40);
  m.fill(0, 0, 9, 39, Cell::kClear);
  m.fill(10, 0, 10, 39, Cell::kObstacle);
  for (int k = 0; k < 3; ++k) m.fill(12 + 3 * k, 1, 12 + 3 * k, 1, Cell::kClear);
  for (int k = 0; k < 17; ++k) {
    const int i = 12 + 4 * (k % 10), j = 10 + 4 * (k / 10);
    m.fill(i, j, i + 1, j + 1, Cell::kClear);
  }
  FrontierBidderConfig cfg = config(0.30, 1.5);
  FrontierBidder bidder(cfg);
  msg::Bid bid;
  EXPECT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(4, 10), &bid), BidStatus::kNoFrontier);
  EXPECT_EQ(bidder.stats().unreachable_clusters, 20u);
  EXPECT_EQ(bidder.stats().clusters_dropped, 4u);
  ASSERT_EQ(bid.n_unreachable, msg::kMaxUnreachable);
  EXPECT_EQ(bid.unreachable_dropped, 4u);  // the 3 singles and one 2 × 2: counted, not silently cut
  for (std::size_t k = 0; k < bid.n_unreachable; ++k) {
    EXPECT_EQ(bid.unreachable[k].cells, 4u) << k;
    EXPECT_EQ(bid.unreachable[k].kind, msg::UnreachableKind::kDisconnected);
  }
}

TEST(FrontierBids, RobotPressedAgainstAWallStillPlans) {
  const Map m = wall_with_gap(5);
  FrontierBidder bidder(config(0.30, 1.5));
  msg::Bid bid;
  // The wall's face is x = 1.5. Cell 8's centre (1.275) is 0.225 m from it, so the
  // inflation blocks cell 8; cell 7 (0.375 m) is free. A robot 0.28 m from the face (2 cm
  // of localisation error into the wall) stands in cell 8: its start cell is allowed.
  const Pose2 pressed{1.5 - 0.28, 3.5 * kRes, 0};
  int i = 0, j = 0;
  ASSERT_TRUE(m.g.cell_of(pressed.x, pressed.y, &i, &j));
  ASSERT_EQ(i, 8);
  EXPECT_EQ(bidder.compute(m.g, m.c.data(), pressed, &bid), BidStatus::kOk);
  EXPECT_GE(bid.n_items, 1);
}

// A robot that has not moved yet: its laser, 0.2 m ahead of its centre, has not seen the
// cells under its own body (nor behind it). Its footprint is free space all the same: it
// must bid for the frontier ahead, not report "no frontier" (which the executive takes
// as "nothing left here" and, with one robot, as the end of exploration: seen in world B
// at the first bid, 2 s into the run).
TEST(FrontierBids, RobotWhoseOwnCellsAreUnseenStillBids) {
  Map m(40, 15);
  // Seen from the laser's cell on (cell 7 begins 0.225 m ahead of the centre, the laser is
  // at 0.2 m); unknown beyond i = 30.
  m.fill(7, 3, 30, 11, Cell::kClear);
  m.fill(7, 2, 30, 2, Cell::kObstacle);
  m.fill(7, 12, 30, 12, Cell::kObstacle);
  FrontierBidder bidder(config(0.30, 2.0));
  msg::Bid bid;
  const Pose2 robot = m.pose_at(5, 7);  // its own cell and the next one ahead unknown
  ASSERT_EQ(m.at(5, 7), Cell::kUnknown);
  ASSERT_EQ(m.at(6, 7), Cell::kUnknown);
  ASSERT_EQ(bidder.compute(m.g, m.c.data(), robot, &bid), BidStatus::kOk);
  EXPECT_GT(bidder.stats().reached_cells, 100u);  // the seen room, through the footprint
  bool far_frontier = false;
  for (std::size_t k = 0; k < bid.n_items; ++k) {
    const auto [i, j] = cell_of(m, bid.items[k]);
    far_frontier = far_frontier || i == 30;
    EXPECT_GT(bid.items[k].gain, 0);
    // Never a cell the robot stands on: it would arrive at once and never move (seen in
    // world B when the footprint first counted as clear).
    EXPECT_GT(std::hypot(bid.items[k].x - robot.x, bid.items[k].y - robot.y), 0.30 + 1e-6) << i << " " << j;
  }
  EXPECT_TRUE(far_frontier) << "the opening at i = 30 is reachable through the footprint";
  // An obstacle under the disc stays one: a robot the map puts inside a wall is refused.
  m.fill(5, 7, 5, 7, Cell::kObstacle);
  EXPECT_EQ(bidder.compute(m.g, m.c.data(), robot, &bid), BidStatus::kRobotInObstacle);
}

TEST(FrontierBids, KeptFrontiersAreSpacedAndCoverTheFrontier) {
  // A clear room 30 × 20 cells, its whole top edge open to unknown: 30 frontier cells.
  Map m(30, 30);
  m.fill(0, 0, 29, 19, Cell::kClear);
  for (double spacing : {0.30, 0.50}) {
    FrontierBidderConfig cfg = config(0.0, 1.0);
    cfg.frontier_spacing_m = spacing;
    FrontierBidder bidder(cfg);
    msg::Bid bid;
    ASSERT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(15, 2), &bid), BidStatus::kOk);
    ASSERT_EQ(bid.n_items, bidder.stats().candidates);  // all bid (< 48)
    ASSERT_GT(bid.n_items, 5);
    for (std::size_t a = 0; a < bid.n_items; ++a)
      for (std::size_t b = a + 1; b < bid.n_items; ++b)
        EXPECT_GE(std::hypot(bid.items[a].x - bid.items[b].x, bid.items[a].y - bid.items[b].y), spacing - 1e-9);
    // An open room: the 8-connected path cost is the octile distance, exactly.
    for (std::size_t k = 0; k < bid.n_items; ++k) {
      const auto [fi, fj] = cell_of(m, bid.items[k]);
      const int dx = std::abs(fi - 15), dy = std::abs(fj - 2);
      const double octile = (std::max(dx, dy) - std::min(dx, dy) + std::sqrt(2.0) * std::min(dx, dy)) * kRes;
      EXPECT_NEAR(bid.items[k].cost, octile, 1e-9) << "frontier (" << fi << ", " << fj << ")";
    }
    // Greedy thinning is maximal: every frontier cell is within the spacing of a kept one.
    for (int i = 0; i < 30; ++i) {
      const Vec2 f = m.g.center(i, 19);
      double nearest = 1e9;
      for (std::size_t k = 0; k < bid.n_items; ++k)
        nearest = std::min(nearest, std::hypot(bid.items[k].x - f.x(), bid.items[k].y - f.y()));
      EXPECT_LT(nearest, spacing) << "frontier cell " << i;
    }
  }
}

TEST(FrontierBids, WallsStopBothFloodFills) {
  // South room clear (i 0..9, j 0..9), unknown east of it (i >= 10, j <= 9); a wall row
  // j = 10; unknown north of it (j >= 11) except a clear pocket i 0..4, j 11..13 that
  // only the wall separates from the robot.
  Map m(30, 20);
  m.fill(0, 0, 9, 9, Cell::kClear);
  m.fill(0, 10, 29, 10, Cell::kObstacle);
  m.fill(0, 11, 4, 13, Cell::kClear);
  FrontierBidderConfig cfg = config(0.0, 1.5);  // 10 cells: the disc reaches past the wall
  FrontierBidder bidder(cfg);
  msg::Bid bid;
  ASSERT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(3, 3), &bid), BidStatus::kOk);
  // Pocket frontier cells: (4, 11..13) and (0..3, 13): never reached through the wall.
  EXPECT_EQ(bidder.stats().unreachable_frontier_cells, 7u);
  EXPECT_EQ(bidder.stats().frontier_cells, 10u + 7u);
  ASSERT_GE(bid.n_items, 1);
  const double r2 = (1.5 / kRes) * (1.5 / kRes) + 1e-9;
  bool north_was_in_range = false;
  for (std::size_t k = 0; k < bid.n_items; ++k) {
    const auto [fi, fj] = cell_of(m, bid.items[k]);
    EXPECT_EQ(fi, 9);
    // Brute force without connectivity: the east unknown cells in range (convex: all connected).
    std::size_t east = 0, north = 0;
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 30; ++i)
        if (m.at(i, j) == Cell::kUnknown && (i - fi) * (i - fi) + (j - fj) * (j - fj) <= r2) ++(j <= 9 ? east : north);
    north_was_in_range = north_was_in_range || north > 0;
    EXPECT_EQ(bid.items[k].gain, static_cast<double>(east)) << "frontier (" << fi << ", " << fj << ")";
    EXPECT_LE(bid.items[k].igr_max_y, 10 * kRes + 1e-12);  // the IGR ends below the wall
  }
  EXPECT_TRUE(north_was_in_range);  // the wall, not the range, kept the north out
}

// The unknown behind a hole of one or two cells in a wall (the laser missed wall cells
// at a grazing angle), or inside a block whose outline lacks a cell, is not gain: the
// gain flood does not cross a run of <= wall_gap_m of unknown cells closed by obstacles.
// A doorway wider than that still bids everything beyond it; wall_gap_m = 0 restores the
// plain flood (the hole then bids the whole unknown behind the wall).
TEST(FrontierBids, UnknownBehindAHoleInAWallOrInsideABlockIsNotGain) {
  // Clear room j 0..9; wall row j = 10 with a 1-cell hole at i = 3, a 2-cell hole at
  // i = 7..8, a 3-cell hole at i = 14..16 (one more than the rule's two cells) and a 6-cell
  // (0.9 m) doorway at i = 20..25 (more than the 1.5 m range from the small holes);
  // unknown beyond (j >= 11).
  // A block outline i 2..7, j 3..8 in the room with one side cell (7, 5) missing and
  // its interior unknown.
  Map m(30, 20);
  m.fill(0, 0, 29, 9, Cell::kClear);
  m.fill(0, 10, 29, 10, Cell::kObstacle);
  m.fill(3, 10, 3, 10, Cell::kUnknown);
  m.fill(7, 10, 8, 10, Cell::kUnknown);
  m.fill(14, 10, 16, 10, Cell::kUnknown);
  m.fill(20, 10, 25, 10, Cell::kUnknown);
  m.fill(2, 3, 7, 8, Cell::kObstacle);
  m.fill(3, 4, 6, 7, Cell::kUnknown);
  m.fill(7, 5, 7, 5, Cell::kUnknown);
  auto items_near = [&](const msg::Bid& bid, int i0, int i1, int j0, int j1) {
    std::vector<msg::BidItem> out;
    for (std::size_t k = 0; k < bid.n_items; ++k) {
      const auto [i, j] = cell_of(m, bid.items[k]);
      if (i >= i0 && i <= i1 && j >= j0 && j <= j1) out.push_back(bid.items[k]);
    }
    return out;
  };
  FrontierBidderConfig cfg = config(0.0, 1.5);
  cfg.frontier_spacing_m = 0.0;  // every frontier cell is a candidate
  ASSERT_DOUBLE_EQ(cfg.wall_gap_m, 0.30);  // the default: runs of up to 2 cells at 0.15 m
  {
    FrontierBidder bidder(cfg);
    msg::Bid bid;
    ASSERT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(15, 2), &bid), BidStatus::kOk);
    EXPECT_TRUE(items_near(bid, 3, 3, 9, 9).empty());     // the 1-cell hole
    EXPECT_TRUE(items_near(bid, 7, 8, 9, 9).empty());     // the 2-cell hole
    EXPECT_TRUE(items_near(bid, 8, 8, 5, 5).empty());     // the block's missing side cell
    EXPECT_EQ(bidder.stats().below_min_gain, 4u);         // those four frontier cells
    // One gap cell met by each of those four floods, and both cells of the 2-cell hole met
    // from behind by each of the 3-cell hole's three floods (within 10 cells of them).
    EXPECT_EQ(bidder.stats().wall_gap_cells, 4u + 6u);
    const auto wider = items_near(bid, 14, 16, 9, 9);
    ASSERT_EQ(wider.size(), 3u) << "a 3-cell hole is an opening at wall_gap_m = 0.3 m";
    for (const auto& item : wider) EXPECT_GT(item.gain, 20.0);
    const auto door = items_near(bid, 20, 25, 9, 9);
    ASSERT_EQ(door.size(), 6u);  // the doorway bids all it sees
    for (const auto& item : door) {
      const auto [fi, fj] = cell_of(m, item);
      // No run of <= 2 unknown cells between obstacles lies in this doorway's flood.
      EXPECT_EQ(item.gain, static_cast<double>(reference_gain(m, fi, fj, 1.5).count)) << fi;
    }
  }
  cfg.wall_gap_m = 0.0;
  {
    FrontierBidder bidder(cfg);
    msg::Bid bid;
    ASSERT_EQ(bidder.compute(m.g, m.c.data(), m.pose_at(15, 2), &bid), BidStatus::kOk);
    const auto hole = items_near(bid, 3, 3, 9, 9);
    ASSERT_EQ(hole.size(), 1u);
    EXPECT_EQ(hole[0].gain, static_cast<double>(reference_gain(m, 3, 9, 1.5).count));
    EXPECT_GT(hole[0].gain, 20.0);  // the unknown behind the wall
    const auto block = items_near(bid, 8, 8, 5, 5);
    ASSERT_EQ(block.size(), 1u);
    EXPECT_EQ(block[0].gain, 1.0 + 16.0);  // the missing cell and the 4 x 4 interior
    EXPECT_EQ(bidder.stats().wall_gap_cells, 0u);
  }
}

// A wall along a diagonal (the 4-connected flood does not leak between its cells) with
// one cell missing: the gap is closed along the diagonal too.
TEST(FrontierBids, AOneCellGapInADiagonalWallIsNotAnOpening) {
  Map m(12, 12);
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 12; ++i) m.c[m.g.index(i, j)] = i > j ? Cell::kClear : (i == j ? Cell::kObstacle : Cell::kUnknown);
  m.fill(5, 5, 5, 5, Cell::kUnknown);  // the missing wall cell: frontier cells (6, 5) and (5, 4)
  FrontierBidderConfig cfg = config(0.0, 1.5);
  cfg.frontier_spacing_m = 0.0;
  msg::Bid bid;
  FrontierBidder with_rule(cfg);
  with_rule.compute(m.g, m.c.data(), m.pose_at(10, 1), &bid);
  EXPECT_EQ(with_rule.stats().frontier_cells, 2u);
  EXPECT_EQ(with_rule.stats().below_min_gain, 2u);
  EXPECT_EQ(bid.n_items, 0);
  cfg.wall_gap_m = 0.0;
  FrontierBidder without(cfg);
  ASSERT_EQ(without.compute(m.g, m.c.data(), m.pose_at(10, 1), &bid), BidStatus::kOk);
  ASSERT_EQ(bid.n_items, 2);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto [fi, fj] = cell_of(m, bid.items[k]);
    EXPECT_EQ(bid.items[k].gain, static_cast<double>(reference_gain(m, fi, fj, 1.5).count));
    EXPECT_GT(bid.items[k].gain, 20.0);  // the unknown side, through the gap
  }
}

// The area to explore (the building's outline): unknown cells outside it are not gain
// and clear cells outside it are not frontier cells, so the grid's margin around the
// building does not pull robots to its outer walls.
TEST(FrontierBids, UnknownOutsideTheAreaIsNotGainAndItsClearCellsAreNotFrontiers) {
  // Clear i 0..9; unknown beyond; a clear patch i 20..22 (seen through a window, outside).
  Map m(30, 10);
  m.fill(0, 0, 9, 9, Cell::kClear);
  m.fill(20, 0, 22, 9, Cell::kClear);
  FrontierBidderConfig cfg = config(0.0, 1.5);
  cfg.frontier_spacing_m = 0.0;
  FrontierBidder whole(cfg);
  msg::Bid bid;
  ASSERT_EQ(whole.compute(m.g, m.c.data(), m.pose_at(2, 5), &bid), BidStatus::kOk);
  EXPECT_EQ(whole.stats().frontier_cells, 10u + 20u);  // i = 9, and i = 20 and 22 (unreachable)
  ASSERT_EQ(bid.n_items, 10);
  EXPECT_GT(bid.items[0].gain, 40.0);
  cfg.has_area = true;
  // Cell centres (i + 0.5)·res inside: i <= 12 (12.5 < 13.4 < 13.5) and j >= 2 (1.5 < 2.4 < 2.5).
  cfg.area_min_x = -5.0, cfg.area_min_y = 2.4 * kRes;
  cfg.area_max_x = 13.4 * kRes, cfg.area_max_y = 5.0;
  FrontierBidder inside(cfg);
  ASSERT_EQ(inside.compute(m.g, m.c.data(), m.pose_at(2, 5), &bid), BidStatus::kOk);
  EXPECT_EQ(inside.stats().frontier_cells, 8u);  // (9, 2..9): the patch and rows 0..1 are outside
  EXPECT_EQ(inside.stats().unreachable_frontier_cells, 0u);
  EXPECT_GT(inside.stats().outside_area_cells, 0u);
  ASSERT_EQ(bid.n_items, 8);
  for (std::size_t k = 0; k < bid.n_items; ++k) {
    EXPECT_EQ(bid.items[k].gain, 24.0);  // i 10..12 x j 2..9, all within 10 cells of i = 9
    EXPECT_NEAR(bid.items[k].igr_max_x, 13 * kRes, 1e-9);
    EXPECT_NEAR(bid.items[k].igr_min_y, 2 * kRes, 1e-9);
  }
  cfg.area_min_x = 1e12, cfg.area_max_x = 2e12;  // entirely off the map: nothing, and no overflow
  FrontierBidder far(cfg);
  EXPECT_EQ(far.compute(m.g, m.c.data(), m.pose_at(2, 5), &bid), BidStatus::kNoFrontier);
  cfg.area_min_x = -5.0, cfg.area_max_x = 13.4 * kRes;
  cfg.area_max_x = cfg.area_min_x;
  EXPECT_THROW(FrontierBidder{cfg}, std::invalid_argument);
}

// Two frontiers: near and small (a 3-cell unknown niche 1 m away), far and large (an
// unknown hall 6 m away): the exchange rate decides the order.
TEST(FrontierBids, RanksByGainMinusRateTimesCost) {
  Map m(60, 20);
  m.fill(0, 0, 59, 19, Cell::kObstacle);
  m.fill(1, 9, 45, 11, Cell::kClear);              // corridor rows 9..11 from i = 1 to 45
  m.fill(46, 1, 58, 18, Cell::kUnknown);           // the hall
  m.fill(8, 12, 8, 12, Cell::kUnknown);            // the niche above (8, 11)
  FrontierBidderConfig cfg = config(0.0, 3.0);
  cfg.gain_per_metre = 0;
  cfg.wall_gap_m = 0;  // the niche is one unknown cell between two wall cells: a wall gap otherwise
  FrontierBidder gain_only(cfg);
  msg::Bid bid;
  ASSERT_EQ(gain_only.compute(m.g, m.c.data(), m.pose_at(2, 10), &bid), BidStatus::kOk);
  ASSERT_GE(bid.n_items, 2);
  EXPECT_EQ(cell_of(m, bid.items[0]).first, 45);
  EXPECT_EQ(bid.items[bid.n_items - 1].gain, 1.0);  // the niche: one cell
  EXPECT_EQ(cell_of(m, bid.items[bid.n_items - 1]), (std::pair{8, 11}));
  // Rate so high that 1 m of travel outweighs the hall: the niche, 6 cells away, first.
  cfg.gain_per_metre = 1e4;
  FrontierBidder cost_heavy(cfg);
  ASSERT_EQ(cost_heavy.compute(m.g, m.c.data(), m.pose_at(2, 10), &bid), BidStatus::kOk);
  EXPECT_EQ(cell_of(m, bid.items[0]), (std::pair{8, 11}));
  for (std::size_t k = 1; k < bid.n_items; ++k) {
    const double prev = bid.items[k - 1].gain - 1e4 * bid.items[k - 1].cost;
    EXPECT_GE(prev, bid.items[k].gain - 1e4 * bid.items[k].cost);
  }
}

TEST(FrontierBids, MaxItemsCapsToTheBestInOrder) {
  Map m(40, 30);
  m.fill(0, 0, 39, 19, Cell::kClear);
  FrontierBidderConfig cfg = config(0.0, 1.2);
  cfg.gain_per_metre = 3.0;
  FrontierBidder all(cfg);
  msg::Bid full;
  ASSERT_EQ(all.compute(m.g, m.c.data(), m.pose_at(5, 5), &full), BidStatus::kOk);
  ASSERT_GT(full.n_items, 5);
  for (std::size_t k = 1; k < full.n_items; ++k)
    EXPECT_GE(full.items[k - 1].gain - 3.0 * full.items[k - 1].cost, full.items[k].gain - 3.0 * full.items[k].cost);
  cfg.max_items = 5;
  FrontierBidder capped(cfg);
  msg::Bid five;
  ASSERT_EQ(capped.compute(m.g, m.c.data(), m.pose_at(5, 5), &five), BidStatus::kOk);
  ASSERT_EQ(five.n_items, 5);
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(five.items[k].x, full.items[k].x);
    EXPECT_EQ(five.items[k].y, full.items[k].y);
  }
}

void expect_rejected(FrontierBidderConfig c, const std::string& name) {
  try {
    FrontierBidder b(c);
    ADD_FAILURE() << name << " accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(FrontierBids, BadConfigIsRejectedNamingTheParameter) {
  const FrontierBidderConfig ok = config(0.3, 4.0);
  EXPECT_NO_THROW(FrontierBidder{ok});
  auto with = [&](auto edit) {
    FrontierBidderConfig c = ok;
    edit(c);
    return c;
  };
  expect_rejected(with([](auto& c) { c.robot_radius_m = -0.1; }), "robot_radius_m");
  expect_rejected(with([](auto& c) { c.max_items = msg::kMaxBids + 1; }), "max_items");
  expect_rejected(with([](auto& c) { c.max_items = 0; }), "max_items");
  expect_rejected(with([](auto& c) { c.max_cells = 0; }), "max_cells");
  expect_rejected(with([](auto& c) { c.sensor_range_m = 0; }), "sensor_range_m");
  expect_rejected(with([](auto& c) { c.frontier_spacing_m = std::nan(""); }), "frontier_spacing_m");
  expect_rejected(with([](auto& c) { c.min_gain_cells = 0; }), "min_gain_cells");
  expect_rejected(with([](auto& c) { c.gain_per_metre = -1; }), "gain_per_metre");
  expect_rejected(with([](auto& c) { c.wall_gap_m = -0.1; }), "wall_gap_m");
  expect_rejected(with([](auto& c) { c.wall_gap_m = 1.5; }), "wall_gap_m");
}

TEST(FrontierBids, RefusesMapsItCannotHoldAndRobotsOffTheMap) {
  const Map m = corridor();  // 40 × 15 = 600 cells
  FrontierBidderConfig cfg = config(0.05, 0.9);
  cfg.max_cells = 599;
  FrontierBidder small(cfg);
  msg::Bid bid;
  bid.n_items = 7;
  EXPECT_EQ(small.compute(m.g, m.c.data(), m.pose_at(3, 7), &bid), BidStatus::kMapTooLarge);
  EXPECT_EQ(bid.n_items, 0);
  cfg.max_cells = 600;  // exactly fits
  FrontierBidder exact(cfg);
  EXPECT_EQ(exact.compute(m.g, m.c.data(), m.pose_at(3, 7), &bid), BidStatus::kOk);
  EXPECT_EQ(exact.compute(m.g, m.c.data(), {0.9, 0.0, 0}, &bid), BidStatus::kRobotOutsideMap);
  EXPECT_EQ(exact.compute(m.g, m.c.data(), {1.0 + 40 * kRes, 0.0, 0}, &bid), BidStatus::kRobotOutsideMap);
  EXPECT_EQ(exact.compute(m.g, m.c.data(), {std::nan(""), 0.0, 0}, &bid), BidStatus::kRobotOutsideMap);
  EXPECT_EQ(exact.compute(m.g, m.c.data(), m.pose_at(10, 5), &bid), BidStatus::kRobotInObstacle);
  EXPECT_EQ(exact.compute(m.g, nullptr, m.pose_at(3, 7), &bid), BidStatus::kBadMap);
  GridGeometry zero_res = m.g;
  zero_res.resolution = 0;
  EXPECT_EQ(exact.compute(zero_res, m.c.data(), m.pose_at(3, 7), &bid), BidStatus::kBadMap);
  EXPECT_EQ(bid.n_items, 0);
}

#ifndef CAIRN_SANITIZED
TEST(FrontierBids, ComputeAllocatesNothing) {
  Map m(200, 150);  // an open hall, half known, with pillars
  m.fill(0, 0, 199, 74, Cell::kClear);
  for (int i = 10; i < 200; i += 20) m.fill(i, 20, i + 1, 21, Cell::kObstacle);
  FrontierBidderConfig cfg = config(0.3, 4.0);
  cfg.max_cells = m.g.cells();
  FrontierBidder bidder(cfg);
  msg::Bid bid;
  const Map door = room_behind_door();  // the unreachable clusters too
  testing::start_counting_allocations();
  const BidStatus first = bidder.compute(m.g, m.c.data(), m.pose_at(100, 10), &bid);
  const BidStatus behind_door = bidder.compute(door.g, door.c.data(), door.pose_at(4, 10), &bid);
  const std::uint16_t clusters = bid.n_unreachable;
  const BidStatus second = bidder.compute(m.g, m.c.data(), m.pose_at(30, 60), &bid);
  const std::uint64_t allocations = testing::stop_counting_allocations();
  EXPECT_EQ(first, BidStatus::kOk);
  EXPECT_EQ(second, BidStatus::kOk);
  EXPECT_EQ(behind_door, BidStatus::kNoFrontier);
  EXPECT_EQ(clusters, 1);
  EXPECT_EQ(bid.n_items, msg::kMaxBids);
  EXPECT_EQ(allocations, 0u);
}
#endif

}  // namespace
}  // namespace cairn::explore
