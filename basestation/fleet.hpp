// The base station's view of the fleet: who is there, in what state, when last
// heard from. Pure bookkeeping on plain data (time is passed in), so it is
// testable without DDS.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>

#include "common/clock.hpp"

namespace cairn::base {

enum class Presence { kAlive, kStale, kLost, kLeft };
const char* presence_name(Presence p);

struct RobotEntry {
  std::uint16_t id = 0;
  std::string name;
  std::string mode;
  Presence presence = Presence::kAlive;
  Nanos first_seen = 0;
  Nanos last_seen = 0;
  std::uint32_t last_seq = 0;
  std::uint64_t messages = 0;
  std::uint32_t joins = 0;
};

/// Who gets a row: every listed robot and every robot the fusion has admitted (its own cap
/// bounds those); other robots only while fewer than `max_unlisted` of them hold a row. The
/// rest are counted, not shown: a hostile or broken publisher cycling through ids cannot
/// grow the table (or flood the console) without bound, nor take an admitted robot's row.
/// When the unlisted rows are full, the row of the unlisted robot lost or gone longest ago
/// makes room for a new one.
struct FleetAdmission {
  std::set<std::uint16_t> listed;  // the configured fleet ([[robot]] ids)
  std::size_t max_unlisted = 8;    // [unknown_robot] max_robots
  std::function<bool(std::uint16_t)> admitted;  // the fusion's admission (may be empty)
};

class Fleet {
 public:
  /// Called with a one-line description of each change (joined, lost, left, stale, back).
  using EventSink = std::function<void(const std::string&)>;

  Fleet(Nanos stale_after, EventSink sink, FleetAdmission admission)
      : stale_after_(stale_after), sink_(std::move(sink)), admission_(std::move(admission)) {}

  void on_status(std::uint16_t id, const std::string& name, const std::string& mode, std::uint32_t seq, Nanos now);
  /// The DDS layer saw the robot's writer vanish (liveliness lost) or dispose (clean shutdown).
  void on_lost(std::uint16_t id, Nanos now);
  void on_left(std::uint16_t id, Nanos now);
  /// Marks silent robots stale.
  void tick(Nanos now);

  /// A fixed-width table of every robot ever seen.
  std::string table(Nanos now) const;
  const std::map<std::uint16_t, RobotEntry>& robots() const { return robots_; }
  std::size_t alive_count() const;
  /// Statuses not shown because their robot is not listed and the unlisted rows are full.
  std::uint64_t refused() const { return refused_; }

 private:
  void emit(const std::string& s) {
    if (sink_) sink_(s);
  }
  Nanos stale_after_;
  EventSink sink_;
  FleetAdmission admission_;
  bool privileged(std::uint16_t id) const { return admission_.listed.contains(id) || (admission_.admitted && admission_.admitted(id)); }
  bool evict_gone_unlisted();  // frees the row of the unlisted robot lost or gone longest ago
  std::map<std::uint16_t, RobotEntry> robots_;
  std::set<std::uint16_t> unlisted_;  // rows held under the max_unlisted cap
  std::uint64_t refused_ = 0;
};

}  // namespace cairn::base
