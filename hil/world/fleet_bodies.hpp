// The robots' bodies in one world shared by several threads (the HIL bench's "robots
// --shared-world"): each robot's physics thread moves its own body here, and each laser
// thread copies the others' to cast rays at them. One mutex guards all bodies, so a move
// is checked against the others' current poses and committed in one critical section: two
// robots moving at once can never both commit overlapping poses.
//
// The bodies are fixed at construction (no allocation afterwards): the threads only look
// up, copy and overwrite.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "common/se2.hpp"

namespace cairn::hil {

struct Body {
  int id = 0;
  Pose2 pose;
  double radius = 0;
};

class FleetBodies {
 public:
  /// All robots, ids distinct and > 0; throws std::invalid_argument otherwise.
  explicit FleetBodies(std::vector<Body> bodies);

  std::size_t size() const { return bodies_.size(); }
  /// Copies every body but `id` into `out` (room for size() - 1); returns how many.
  std::size_t snapshot_others(int id, std::span<Body> out) const;
  Body body(int id) const;

  /// Moves body `id` to `to` unless that brings it closer to another body it then
  /// overlaps (a contact): returns 0 when moved, else the id of the body in the way (the
  /// body stays where it was). A body already overlapping another (placed so) may move
  /// away or keep its distance; staying in place always succeeds.
  int try_move(int id, const Pose2& to);

  /// Refused moves between robots a and b (either one moving), and contacts: runs of
  /// refusals, a new one starting once the two were apart by more than kContactRelease.
  std::uint64_t refused_moves(int a, int b) const;
  std::uint64_t contacts(int a, int b) const;
  static constexpr double kContactRelease = 0.05;  // m of clearance that ends a contact

 private:
  struct Pair {
    std::uint64_t refused = 0, contacts = 0;
    bool touching = false;
  };
  std::size_t index(int id) const;  // throws std::out_of_range for an unknown id
  Pair& pair(std::size_t i, std::size_t j) { return pairs_[std::min(i, j) * bodies_.size() + std::max(i, j)]; }
  const Pair& pair(std::size_t i, std::size_t j) const { return pairs_[std::min(i, j) * bodies_.size() + std::max(i, j)]; }

  mutable std::mutex mutex_;
  std::vector<Body> bodies_;  // fixed after construction
  std::vector<Pair> pairs_;   // size² (upper triangle used)
};

}  // namespace cairn::hil
