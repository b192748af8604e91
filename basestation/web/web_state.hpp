// What the web view shows, as JSON text built on the base's main loop from its own state
// (fleet, fusion, explore, map): the live state (robots with pose, 3σ ellipse, bounded
// trail, panel fields with the RT loop's figures, task with its information-gain region,
// latest bid; landmarks with ellipses; the exploration's state; recent command results).
// The map goes in tiles (web_map_tiles.hpp).
// The text is handed to WebServer as an immutable snapshot.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "basestation/explore/task_allocator.hpp"
#include "basestation/fleet.hpp"
#include "basestation/fusion.hpp"
#include "basestation/mapper/grid.hpp"
#include "basestation/web/web_command.hpp"
#include "common/clock.hpp"

namespace cairn::base {


/// The RobotStatus fields the panel shows beyond the fleet table (from the robot's latest status).
struct WebRobotStatus {
  float battery_voltage = 0, battery_soc = 0;
  std::uint8_t stop_reason = 0;
  std::string stop_text;
  std::uint8_t nav_state = 0;
  // The RT loop (RobotStatus): period mean and p99, worst jitter, cycles, deadline misses, overflows.
  float loop_period_mean_us = 0, loop_period_p99_us = 0, loop_jitter_max_us = 0;
  std::uint32_t loop_cycles = 0, deadline_misses = 0, queue_overflows = 0;
  struct Device {
    std::string name, reason;
    std::uint8_t state = 0;
  };
  std::vector<Device> devices;
};

inline constexpr std::size_t kWebTrailPoints = 400;      // per robot: older points are dropped
inline constexpr double kWebTrailStepM = 0.05;           // a point when the robot moved this far
inline constexpr std::size_t kWebMaxLandmarks = 1000;    // beyond: counted, not sent
inline constexpr std::size_t kWebCommandHistory = 10;    // results kept for the page
inline constexpr std::size_t kWebMaxGivenUp = 100;       // given-up frontier spots sent

class WebState {
 public:
  void on_status(std::uint16_t robot, WebRobotStatus status);
  /// The main loop's verdict on a queued command ("accepted" or why not); a later result
  /// for the same id (a reset that ended) replaces the earlier one.
  void on_command_result(std::uint64_t id, const WebCommand& command, std::string result);
  /// Samples the trails and returns the state JSON. `explore` (the exploration executive's
  /// allocator) may be null: no exploration.
  std::string state_json(Nanos now, const Fleet& fleet, const Fusion* fusion, const explore::TaskAllocator* explore);

 private:
  struct Result {
    std::uint64_t id;
    WebCommand command;
    std::string result;
  };
  std::map<std::uint16_t, WebRobotStatus> status_;
  std::map<std::uint16_t, std::deque<Vec2>> trails_;
  std::deque<Result> results_;
};

std::string base64(const std::vector<std::uint8_t>& bytes);

}  // namespace cairn::base
