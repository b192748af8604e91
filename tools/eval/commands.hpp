// cairn-eval's subcommands.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace cairn::eval {

struct CcmlPaperOptions {
  int scenario = 1;
  std::string out_dir = "ccml-paper";
  std::uint64_t seed = 1;
  int iterations = 1;
  bool json = false;
};
int ccml_paper(const CcmlPaperOptions& o);
int vehicles_needed_cmd(double initial_sigma, double desired_sigma, bool as_json);

struct MrclamCmdOptions {
  std::string dir;
  std::string association = "both";  // labels | jcbb | both
  double duration = 0;
  int iterations = 1;
  std::string calibrate_on;     // a dataset with robot ground truth: noise fitted on it (docs/ccml.md)
  double calibrate_until = 300;  // ... over its first S seconds; on the evaluated dataset, scored after them
  double score_from = 0;         // pose RMSE / NEES only from S seconds after the start
  bool json = false;
};
int mrclam(const MrclamCmdOptions& o);

struct ScansCmdOptions {
  std::string log;
  double sigma_xy = 0.10, sigma_theta_deg = 5.0;
  std::uint64_t seed = 1;
  std::size_t max_pairs = 0;
  bool no_mapper = false;
  bool json = false;
};
int scans(const ScansCmdOptions& o);

struct ExploreCmdOptions {
  std::string world;
  std::vector<int> robots{1, 2, 3};
  int runs = 10;
  std::string mode = "coordinated";  // coordinated | uncoordinated | both (uncoordinated for counts > 1)
  std::uint64_t seed = 1;            // run k uses seed + k, for every robot count and mode
  bool random_maps = false;          // run k on the world's `random` line with its seed + k
  bool shared_world = false;         // the robots in one world: they see, block and meet each other
  double duration = 900;             // simulated s per run (the cap)
  double cells_per_metre = -1;       // the allocator's exchange rate; < 0: the base's default
  int jobs = 0;                      // runs at once; 0: one per core
  std::string out_dir;               // default explore-<world name>
  bool verbose = false;              // the fleets' log lines too
  bool json = false;
};
int explore(const ExploreCmdOptions& o);

}  // namespace cairn::eval
