// RAII over a Cyclone DDS domain participant, created with a Cairn profile.
#pragma once

#include <dds/dds.h>

#include <string>

#include "common/dds/profile.hpp"

namespace cairn::dds {

/// Owns one DDS entity handle; deletes it (and its children) on destruction.
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t h) : h_(h) {}
  ~Entity() { reset(); }
  Entity(Entity&& o) noexcept : h_(o.h_) { o.h_ = 0; }
  Entity& operator=(Entity&& o) noexcept {
    if (this != &o) {
      reset();
      h_ = o.h_;
      o.h_ = 0;
    }
    return *this;
  }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  dds_entity_t get() const { return h_; }
  void reset() {
    if (h_ > 0) dds_delete(h_);
    h_ = 0;
  }

 private:
  dds_entity_t h_ = 0;
};

class Participant {
 public:
  /// Creates (once per process and domain) the domain with the profile's configuration, then the participant.
  explicit Participant(const DdsProfile& profile);
  /// The last participant of a domain this class created deletes the domain: its threads
  /// stop before the process exits (with the security plugins loaded, a domain left
  /// running crashed at exit while the libraries were unloaded).
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  dds_entity_t handle() const { return pp_.get(); }
  const DdsProfile& profile() const { return profile_; }
  /// "profile loopback (interface lo, ...), domain 0" — for the start-up log line.
  std::string describe() const;

 private:
  DdsProfile profile_;
  Entity pp_;
};

}  // namespace cairn::dds
