// cairn-eval explore end to end: a short grid on the office, its summary against its own
// per-run records, and the random maps of environments D and E.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/support/subprocess.hpp"

namespace cairn {
namespace {

namespace fs = std::filesystem;
const std::string kWorlds = std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/";

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

int run(const std::vector<std::string>& args, std::string* output = nullptr) {
  std::vector<std::string> argv = {CAIRN_EVAL_BIN, "explore"};
  argv.insert(argv.end(), args.begin(), args.end());
  testing::Subprocess p(argv);
  const int rc = p.wait(std::chrono::minutes(4));
  if (output) *output = p.output();
  return rc;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("cairn-explore-cli-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

// The first time in a run's coverage.csv at which coverage reached `level`, or -1.
double first_time_at(const fs::path& csv, double level) {
  std::ifstream f(csv);
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line)) {
    double t = 0, c = 0;
    if (std::sscanf(line.c_str(), "%lf,%lf", &t, &c) == 2 && c >= level) return t;
  }
  return -1;
}

TEST(ExploreCli, OfficeOneAndTwoRobotsBothModes) {
  const fs::path out = fresh_dir("office");
  std::string log;
  ASSERT_EQ(run({"--world", kWorlds + "office.world", "--robots", "1,2", "--runs", "2", "--duration", "120", "--mode",
                 "both", "--seed", "3", "--out", out.string()},
                &log),
            0)
      << log;
  const auto s = nlohmann::json::parse(slurp(out / "summary.json"));
  // One robot twice (both modes are the same runs), two robots twice in both modes.
  ASSERT_EQ(s["groups"].size(), 3u) << s.dump(2);
  ASSERT_EQ(s["runs"].size(), 6u);
  const auto& g1 = s["groups"][0];
  const auto& g2 = s["groups"][1];
  const auto& u2 = s["groups"][2];
  EXPECT_EQ(g1["mode"], "coordinated");
  EXPECT_EQ(g1["robots"], 1);
  EXPECT_EQ(g2["robots"], 2);
  EXPECT_EQ(u2["mode"], "uncoordinated");
  // Every run reached half the office within 120 s, two robots sooner than one on the
  // mean of two runs (seeds 3, 4: one robot 55 and 85 s, two 45 and 50 s). One run was
  // asserted until the lookahead scaled with speed; then seed 3 alone had two robots at
  // 0.82 of one (45 against 55 s), over the 0.8 bound: single runs vary too much.
  for (const auto& g : s["groups"]) ASSERT_EQ(g["time_to_coverage_s"]["50"]["reached"], 2) << g.dump(2);
  EXPECT_LT(g2["time_to_coverage_s"]["50"]["mean"].get<double>(), 0.8 * g1["time_to_coverage_s"]["50"]["mean"].get<double>());
  // The summary's times are the runs' own records, the maps are sane and written.
  for (std::size_t i = 0; i < s["runs"].size(); ++i) {
    const auto& r = s["runs"][i];
    const std::string name = r["mode"].get<std::string>() + "-r" + std::to_string(r["robots"].get<int>()) + "-run" +
                             std::to_string(i % 2);  // runs in order, two per group
    const fs::path dir = out / "runs" / name;
    EXPECT_DOUBLE_EQ(first_time_at(dir / "coverage.csv", 0.5), r["time_to_coverage_s"]["50"].get<double>()) << name;
    EXPECT_TRUE(fs::is_regular_file(dir / "map.png")) << name;
    EXPECT_GE(r["agreement"].get<double>(), 0.85) << name;
    EXPECT_FALSE(r["failed"].get<bool>());
    EXPECT_EQ(r["seed"], 3 + static_cast<int>(i % 2));
  }
  EXPECT_TRUE(fs::is_regular_file(out / "coverage.png"));
  EXPECT_TRUE(fs::is_regular_file(out / "time_to_coverage.png"));
  EXPECT_NE(slurp(out / "table.md").find("| uncoordinated | 2 | 2 |"), std::string::npos);
  fs::remove_all(out);
}

// World B, one robot, the seeds that first showed two defects of the robot's start: with
// the cells under the robot unknown, exploration ended at the first bid (seeds 1 and 3,
// coverage 0.145); with them counted as frontier, the robot "arrived" at its own cell
// every round and never moved (seeds 2 and 4, 0.147). Every run must leave the start.
TEST(ExploreCli, EveryRobotLeavesItsStartInTwoCorridors) {
  const fs::path out = fresh_dir("corridors");
  std::string log;
  ASSERT_EQ(run({"--world", kWorlds + "two_corridors.world", "--robots", "1", "--runs", "4", "--duration", "60", "--seed",
                 "1", "--out", out.string()},
                &log),
            0)
      << log;
  const auto s = nlohmann::json::parse(slurp(out / "summary.json"));
  ASSERT_EQ(s["runs"].size(), 4u);
  for (const auto& r : s["runs"]) {
    EXPECT_GT(r["final_coverage"].get<double>(), 0.3) << r.dump();
    EXPECT_GT(r["distance_m"].get<double>(), 5.0) << r.dump();
    EXPECT_FALSE(r["explored"].get<bool>()) << r.dump();  // not in 60 s
  }
  fs::remove_all(out);
}

TEST(ExploreCli, RandomMapsAreOtherInstancesOfTheWorld) {
  const fs::path out = fresh_dir("random");
  std::string log;
  ASSERT_EQ(run({"--world", kWorlds + "random15.world", "--random-maps", "--robots", "1", "--runs", "2", "--duration",
                 "10", "--out", out.string()},
                &log),
            0)
      << log;
  const std::string m0 = slurp(out / "worlds" / "map0.world"), m1 = slurp(out / "worlds" / "map1.world");
  EXPECT_NE(m0.find("random 0.15 42 1.0"), std::string::npos) << m0;  // run 0: the shipped map
  EXPECT_NE(m1.find("random 0.15 43 1.0"), std::string::npos) << m1;
  const auto s = nlohmann::json::parse(slurp(out / "summary.json"));
  ASSERT_EQ(s["runs"].size(), 2u);
  EXPECT_NE(s["runs"][0]["world"], s["runs"][1]["world"]);
  fs::remove_all(out);
}

TEST(ExploreCli, RefusesRandomMapsOfAWorldWithoutRandomObstacles) {
  const fs::path out = fresh_dir("refuse");
  std::string log;
  EXPECT_EQ(run({"--world", kWorlds + "office.world", "--random-maps", "--runs", "2", "--out", out.string()}, &log), 1);
  EXPECT_NE(log.find("has no 'random FRACTION SEED CELL' line"), std::string::npos) << log;
  fs::remove_all(out);
}

// scripts/explore-tune.sh chooses the allocator's exchange rate on held-out worlds: their
// random maps are not the grid's (seeds 1042.. and 1007.., the grid's 42.. and 7..), and
// the rate given is the runs' own, recorded in the summary; a negative rate is refused.
TEST(ExploreCli, TuningRunsOnHeldOutMapsWithTheRateGiven) {
  const fs::path out = fresh_dir("tune");
  std::string log;
  ASSERT_EQ(run({"--world", kWorlds + "tuning/random15_tune.world", "--random-maps", "--robots", "1", "--runs", "1",
                 "--duration", "10", "--cells-per-metre", "25", "--out", out.string()},
                &log),
            0)
      << log;
  EXPECT_NE(slurp(out / "worlds" / "map0.world").find("random 0.15 1042 1.0"), std::string::npos);
  const auto s = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_DOUBLE_EQ(s["cells_per_metre"].get<double>(), 25.0);
  EXPECT_NE(run({"--world", kWorlds + "tuning/offices_long.world", "--cells-per-metre", "-1", "--out", out.string()}, &log),
            0);
  EXPECT_NE(log.find("cells-per-metre"), std::string::npos) << log;
  for (const char* w : {"offices_long", "random_clutter_tune"}) {  // they load, and the clutter is not the grid's
    ASSERT_EQ(run({"--world", kWorlds + "tuning/" + w + ".world", "--robots", "1", "--runs", "1", "--duration", "10",
                   "--out", (out / w).string()},
                  &log),
              0)
        << log;
  }
  EXPECT_NE(slurp(fs::path(kWorlds) / "tuning" / "random_clutter_tune.world").find("random 0.10 1007 0.5"),
            std::string::npos);
  fs::remove_all(out);
}

}  // namespace
}  // namespace cairn
