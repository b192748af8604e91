// cairn-eval explore's statistics (tools/eval/explore_stats.hpp) on hand-made runs.
#include "tools/eval/explore_stats.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace cairn::eval {
namespace {

ExploreRun make_run(const std::string& mode, int robots, std::optional<double> t50, std::optional<double> t95,
                    double agreement = 0.9) {
  ExploreRun r;
  r.mode = mode;
  r.robots = robots;
  r.time_to[0] = t50;
  r.time_to[2] = t95;
  r.explored = t95.has_value();
  r.explored_at_s = t95.value_or(0) + 50;
  r.agreement = agreement;
  r.final_coverage = t95 ? 0.99 : 0.8;
  return r;
}

TEST(ExploreStats, GroupsByModeThenRobotCountWithMeanSpreadAndReachedRuns) {
  const std::vector<ExploreRun> runs = {
      make_run("uncoordinated", 3, 40, 150), make_run("coordinated", 2, 50, 160), make_run("coordinated", 1, 80, 280),
      make_run("coordinated", 2, 40, 200),   make_run("coordinated", 1, 90, std::nullopt)};
  const auto g = aggregate(runs, 0, 0);
  ASSERT_EQ(g.size(), 3u);
  EXPECT_EQ(g[0].mode, "coordinated");
  EXPECT_EQ(g[0].robots, 1);
  EXPECT_EQ(g[1].robots, 2);
  EXPECT_EQ(g[2].mode, "uncoordinated");
  // Two robots: 95 % at 160 and 200 s.
  EXPECT_EQ(g[1].level[2].reached, 2u);
  EXPECT_DOUBLE_EQ(*g[1].level[2].mean, 180);
  EXPECT_NEAR(*g[1].level[2].sd, 28.2843, 1e-3);  // sample sd of {160, 200}
  EXPECT_DOUBLE_EQ(*g[1].level[2].min, 160);
  EXPECT_DOUBLE_EQ(*g[1].level[2].max, 200);
  EXPECT_FALSE(g[1].level[1].mean);  // 90 %: no run recorded a time
  // One robot: one run reached 95 %, one did not; the mean is over the one, with no sd.
  EXPECT_EQ(g[0].runs, 2u);
  EXPECT_EQ(g[0].completed, 1u);
  EXPECT_EQ(g[0].level[2].reached, 1u);
  EXPECT_DOUBLE_EQ(*g[0].level[2].mean, 280);
  EXPECT_FALSE(g[0].level[2].sd);
  EXPECT_DOUBLE_EQ(g[0].explored_at_mean, 330);
}

TEST(ExploreStats, SpeedupOnlyWhenEveryRunOfBothGroupsReachedTheLevel) {
  std::vector<ExploreRun> runs = {make_run("coordinated", 1, 80, 280), make_run("coordinated", 1, 90, 300),
                                  make_run("coordinated", 2, 50, 160), make_run("coordinated", 2, 40, 200)};
  auto g = aggregate(runs, 0, 0);
  ASSERT_TRUE(speedup(g[0], g[1], 2));
  EXPECT_DOUBLE_EQ(*speedup(g[0], g[1], 2), 290.0 / 180.0);
  runs[1].time_to[2].reset();  // one single-robot run never reached 95 %: its mean would flatter
  g = aggregate(runs, 0, 0);
  EXPECT_FALSE(speedup(g[0], g[1], 2));
}

TEST(ExploreStats, FailureIsAWrongMapNotAnUnfinishedRun) {
  EXPECT_FALSE(is_failure(make_run("coordinated", 1, 80, std::nullopt, 0.80)));
  EXPECT_TRUE(is_failure(make_run("coordinated", 1, 80, 200, 0.70)));
  EXPECT_TRUE(is_failure(make_run("coordinated", 1, 80, 200, std::nan(""))));
  const auto g = aggregate({make_run("coordinated", 1, 80, 200, 0.70), make_run("coordinated", 1, 80, 200, 0.9)}, 0, 0);
  EXPECT_EQ(g[0].failures, 1u);
}

TEST(ExploreStats, MeanCurveHoldsTheLastValueOfRunsThatEnded) {
  ExploreRun a = make_run("coordinated", 2, 5, 10);
  a.curve_t = {0, 5, 10};
  a.curve_coverage = {0.2, 0.6, 0.96};  // explored at 10 s: its curve ends there
  ExploreRun b = make_run("coordinated", 2, 10, 20);
  b.curve_t = {0, 5, 10, 15, 20};
  b.curve_coverage = {0.1, 0.3, 0.5, 0.8, 0.95};
  const auto g = aggregate({a, b}, 5, 20);
  ASSERT_EQ(g[0].curve_t.size(), 5u);
  EXPECT_DOUBLE_EQ(g[0].curve_mean[1], 0.45);
  EXPECT_DOUBLE_EQ(g[0].curve_mean[4], (0.96 + 0.95) / 2);  // a holds 0.96
  EXPECT_DOUBLE_EQ(g[0].curve_min[3], 0.8);
  EXPECT_DOUBLE_EQ(g[0].curve_max[3], 0.96);
}

}  // namespace
}  // namespace cairn::eval
