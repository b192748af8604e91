// The exploration executive's parameters (docs/explore-executive.md), validated once at
// construction: a bad value throws std::invalid_argument naming the parameter.
#pragma once

#include <cstdint>
#include <map>

#include "common/clock.hpp"
#include "common/se2.hpp"

namespace cairn::explore {

struct AllocatorConfig {
  /// After a bid arrives (and no round is already pending), wait this long for the other
  /// robots' bids, then assign with everything that arrived.
  Nanos bid_wait = kNanosPerSecond / 2;
  /// The exchange rate between the two sides of the net utility, in cells of expected gain
  /// per metre of path: u = (1 - d)·i·h − cells_per_metre·c, in cells. The COST side is
  /// scaled (the gain stays a cell count, comparable with min_gain). 40 cells per metre at
  /// 15 cm is about 0.9 m² of new map per metre driven. Chosen by scripts/explore-tune.sh on
  /// held-out worlds only (hil/worlds/tuning; 10, 20, 40, 80 tried; docs/explore.md "Tuning
  /// the exchange rate"); the robots rank their bids with the same rate (gain_per_metre).
  double cells_per_metre = 40.0;
  /// An item is assignable only while its discounted gain (1 − d)·i is above this (cells);
  /// exploration ends when no robot's latest bid has an item with gain above it.
  double min_gain = 20.0;
  /// Seed §4: a frontier cell inside the IGR of the robot's current task has its gain
  /// divided by this (0 < ratio ≤ 1; 1 disables hysteresis). Lower = less switching.
  double hysteresis_ratio = 0.85;
  /// A task whose distance to its target has not fallen by progress_step_m for this long is
  /// taken back.
  Nanos no_progress_timeout = 20 * kNanosPerSecond;
  double progress_step_m = 0.25;
  /// A frontier taken back from a robot is barred for that robot for this long (not forever).
  Nanos bar_duration = 60 * kNanosPerSecond;
  /// A robot within this distance of its target has arrived.
  double arrival_radius_m = 0.3;
  /// Two frontier cells closer than this are the same frontier (the bidder keeps frontier
  /// cells 30 cm apart): a new bid's item this close to the current target continues the
  /// task, and a barred frontier bars items this close to it.
  double same_frontier_m = 0.3;
  /// Giving up on a frontier no robot manages to see (docs/explore-executive.md, "Given-up
  /// frontiers"). An attempt at a spot is a robot on an explore task coming within
  /// look_radius_m of its target (once per task), or the task taken back there (no
  /// progress, stuck). A spot with give_up_attempts attempts is given up: items within
  /// look_radius_m of it are neither assigned nor counted by the end of exploration. A
  /// frontier that survives robots standing beside it lies behind what the laser cannot see
  /// (a pocket too narrow to enter, a wall's unseen cells); bars expire, so without this a
  /// lone robot would go back to it until the run's time ran out. 0 never gives up.
  double look_radius_m = 1.0;
  std::uint32_t give_up_attempts = 2;
  /// false: no discount, each robot takes its own best item (the seed's comparison).
  bool coordinated = true;
  /// When exploration ends, a robot listed here is sent to its start position (global
  /// frame); the others are told to idle.
  std::map<std::uint16_t, Vec2> home;
};

/// Throws std::invalid_argument("AllocatorConfig.<name> ...") for the first bad parameter.
void validate(const AllocatorConfig& c);

}  // namespace cairn::explore
