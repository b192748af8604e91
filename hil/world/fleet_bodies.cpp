#include "hil/world/fleet_bodies.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cairn::hil {

FleetBodies::FleetBodies(std::vector<Body> bodies) : bodies_(std::move(bodies)), pairs_(bodies_.size() * bodies_.size()) {
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    if (bodies_[i].id <= 0) throw std::invalid_argument("FleetBodies: robot ids must be > 0");
    for (std::size_t j = 0; j < i; ++j) {
      if (bodies_[i].id == bodies_[j].id) throw std::invalid_argument("FleetBodies: robot " + std::to_string(bodies_[i].id) + " twice");
    }
  }
}

std::size_t FleetBodies::index(int id) const {
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    if (bodies_[i].id == id) return i;
  }
  throw std::out_of_range("FleetBodies: no robot " + std::to_string(id));
}

std::size_t FleetBodies::snapshot_others(int id, std::span<Body> out) const {
  std::lock_guard lock(mutex_);
  std::size_t n = 0;
  for (const Body& b : bodies_) {
    if (b.id != id && n < out.size()) out[n++] = b;
  }
  return n;
}

Body FleetBodies::body(int id) const {
  std::lock_guard lock(mutex_);
  return bodies_[index(id)];
}

int FleetBodies::try_move(int id, const Pose2& to) {
  std::lock_guard lock(mutex_);
  const std::size_t i = index(id);
  Body& me = bodies_[i];
  const Vec2 from = me.pose.translation(), next = to.translation();
  for (std::size_t j = 0; j < bodies_.size(); ++j) {
    if (j == i) continue;
    const Vec2 other = bodies_[j].pose.translation();
    const double touch = me.radius + bodies_[j].radius;
    const double d_next = (next - other).norm();
    // Refused only when it would overlap AND come closer: bodies placed overlapping can part.
    if (d_next < touch && d_next < (from - other).norm()) {
      Pair& p = pair(i, j);
      ++p.refused;
      if (!p.touching) ++p.contacts;
      p.touching = true;
      return bodies_[j].id;
    }
  }
  me.pose = to;
  for (std::size_t j = 0; j < bodies_.size(); ++j) {
    if (j == i) continue;
    Pair& p = pair(i, j);
    if (p.touching && (next - bodies_[j].pose.translation()).norm() > me.radius + bodies_[j].radius + kContactRelease) {
      p.touching = false;
    }
  }
  return 0;
}

std::uint64_t FleetBodies::refused_moves(int a, int b) const {
  std::lock_guard lock(mutex_);
  return pair(index(a), index(b)).refused;
}

std::uint64_t FleetBodies::contacts(int a, int b) const {
  std::lock_guard lock(mutex_);
  return pair(index(a), index(b)).contacts;
}

}  // namespace cairn::hil
