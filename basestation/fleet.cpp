#include "basestation/fleet.hpp"

#include <cstdio>

namespace cairn::base {

const char* presence_name(Presence p) {
  switch (p) {
    case Presence::kAlive: return "alive";
    case Presence::kStale: return "stale";
    case Presence::kLost: return "LOST";
    case Presence::kLeft: return "left";
  }
  return "?";
}

void Fleet::on_status(std::uint16_t id, const std::string& name, const std::string& mode, std::uint32_t seq, Nanos now) {
  auto it = robots_.find(id);
  const bool inserted = it == robots_.end();
  if (inserted) {
    const bool listed = privileged(id);
    if (!listed && unlisted_.size() >= admission_.max_unlisted && !evict_gone_unlisted()) {
      if (refused_++ == 0) {
        emit("robot " + std::to_string(id) + " refused: not in the configured fleet and " +
             std::to_string(admission_.max_unlisted) + " unlisted robot(s) already shown (further ones are counted)");
      }
      return;
    }
    if (!listed) unlisted_.insert(id);
    it = robots_.try_emplace(id).first;
  }
  RobotEntry& r = it->second;
  if (inserted) {
    r.id = id;
    r.first_seen = now;
    r.joins = 1;
    r.presence = Presence::kAlive;
    emit("robot " + std::to_string(id) + " joined (" + name + ")");
  } else if (r.presence != Presence::kAlive) {
    const Presence before = r.presence;
    r.presence = Presence::kAlive;
    ++r.joins;
    emit("robot " + std::to_string(id) + (before == Presence::kStale ? " is back" : " rejoined") + " (" + name + ")");
  }
  r.name = name;
  r.mode = mode;
  r.last_seen = now;
  r.last_seq = seq;
  ++r.messages;
}

void Fleet::on_lost(std::uint16_t id, Nanos now) {
  auto it = robots_.find(id);
  if (it == robots_.end() || it->second.presence == Presence::kLost || it->second.presence == Presence::kLeft) return;
  it->second.presence = Presence::kLost;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f", nanos_to_seconds(now - it->second.last_seen));
  emit("robot " + std::to_string(id) + " lost (liveliness expired, last heard " + buf + " s ago)");
}

bool Fleet::evict_gone_unlisted() {
  auto oldest = unlisted_.end();
  for (auto it = unlisted_.begin(); it != unlisted_.end(); ++it) {
    const RobotEntry& r = robots_.at(*it);
    if (r.presence != Presence::kLost && r.presence != Presence::kLeft) continue;
    if (oldest == unlisted_.end() || r.last_seen < robots_.at(*oldest).last_seen) oldest = it;
  }
  if (oldest == unlisted_.end()) return false;
  robots_.erase(*oldest);
  unlisted_.erase(oldest);
  return true;
}

void Fleet::on_left(std::uint16_t id, Nanos now) {
  (void)now;
  auto it = robots_.find(id);
  if (it == robots_.end() || it->second.presence == Presence::kLeft) return;
  it->second.presence = Presence::kLeft;
  emit("robot " + std::to_string(id) + " left (clean shutdown)");
}

void Fleet::tick(Nanos now) {
  for (auto& [id, r] : robots_) {
    if (r.presence == Presence::kAlive && now - r.last_seen > stale_after_) {
      r.presence = Presence::kStale;
      emit("robot " + std::to_string(id) + " stale (no status for " + std::to_string((now - r.last_seen) / kNanosPerMilli) +
           " ms)");
    }
  }
}

std::size_t Fleet::alive_count() const {
  std::size_t n = 0;
  for (const auto& [id, r] : robots_) n += r.presence == Presence::kAlive ? 1 : 0;
  return n;
}

std::string Fleet::table(Nanos now) const {
  std::string out;
  char line[160];
  std::snprintf(line, sizeof line, "%4s  %-16s %-8s %-6s %10s %8s\n", "id", "name", "mode", "state", "last seen", "msgs");
  out += line;
  for (const auto& [id, r] : robots_) {
    std::snprintf(line, sizeof line, "%4u  %-16.16s %-8.8s %-6s %8.1f s %8llu\n", static_cast<unsigned>(id), r.name.c_str(),
                  r.mode.c_str(), presence_name(r.presence), nanos_to_seconds(now - r.last_seen),
                  static_cast<unsigned long long>(r.messages));
    out += line;
  }
  return out;
}

}  // namespace cairn::base
