#include "basestation/explore/allocator_config.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cairn::explore {

namespace {
void require(bool ok, const char* name, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("AllocatorConfig.") + name + " " + what);
}
}  // namespace

void validate(const AllocatorConfig& c) {
  require(c.bid_wait >= 0, "bid_wait", "must be >= 0");
  require(std::isfinite(c.cells_per_metre) && c.cells_per_metre >= 0, "cells_per_metre", "must be finite and >= 0");
  require(std::isfinite(c.min_gain) && c.min_gain >= 0, "min_gain", "must be finite and >= 0");
  require(c.hysteresis_ratio > 0 && c.hysteresis_ratio <= 1, "hysteresis_ratio", "must be in (0, 1]");
  require(c.no_progress_timeout > 0, "no_progress_timeout", "must be > 0");
  require(std::isfinite(c.progress_step_m) && c.progress_step_m > 0, "progress_step_m", "must be finite and > 0");
  require(c.bar_duration >= 0, "bar_duration", "must be >= 0");
  require(std::isfinite(c.arrival_radius_m) && c.arrival_radius_m > 0, "arrival_radius_m", "must be finite and > 0");
  require(std::isfinite(c.same_frontier_m) && c.same_frontier_m >= 0, "same_frontier_m", "must be finite and >= 0");
  require(std::isfinite(c.look_radius_m) && c.look_radius_m >= c.arrival_radius_m, "look_radius_m",
          "must be finite and >= arrival_radius_m");
  for (const auto& [id, p] : c.home) {
    require(id != 0, "home", "robot id 0 is the base");
    require(std::isfinite(p.x()) && std::isfinite(p.y()), "home", "positions must be finite");
  }
}

}  // namespace cairn::explore
