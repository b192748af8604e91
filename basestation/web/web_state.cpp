#include "basestation/web/web_state.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "basestation/mapper/export.hpp"
#include "common/stop_reason.hpp"

namespace cairn::base {

namespace {

using nlohmann::json;

// Rounded: the page needs millimetres, not 17 digits (the state goes out 5 times a second).
double mm(double v) { return std::isfinite(v) ? std::round(v * 1000.0) / 1000.0 : 0.0; }

json ellipse(const msg::Cov2& cov) {
  const mapper::Ellipse e = mapper::covariance_ellipse(cov, 3.0);
  return {{"major", mm(e.major)}, {"minor", mm(e.minor)}, {"angle", mm(e.angle)}};
}

json rect(const explore::Rect& r) { return {mm(r.min_x), mm(r.min_y), mm(r.max_x), mm(r.max_y)}; }

// A robot's latest bid: its frontier items (gain in cells, path cost in m, the region) and
// the unreachable clusters, bounded by the IDL's MAX_BIDS and MAX_UNREACHABLE.
json bid_json(const msg::Bid& bid) {
  json items = json::array();
  for (std::size_t k = 0; k < bid.n_items && k < msg::kMaxBids; ++k) {
    const msg::BidItem& it = bid.items[k];
    items.push_back({{"x", mm(it.x)}, {"y", mm(it.y)}, {"gain", mm(it.gain)}, {"cost", mm(it.cost)}, {"igr", rect(explore::igr_of(it))}});
  }
  json unreachable = json::array();
  for (std::size_t k = 0; k < bid.n_unreachable && k < msg::kMaxUnreachable; ++k) {
    const msg::UnreachableCluster& u = bid.unreachable[k];
    unreachable.push_back({{"x", mm(u.x)}, {"y", mm(u.y)}, {"rect", rect({u.min_x, u.min_y, u.max_x, u.max_y})}, {"cells", u.cells}});
  }
  return {{"seq", bid.seq}, {"items", std::move(items)}, {"unreachable", std::move(unreachable)}};
}

const char* task_kind(msg::TaskKind k) {
  switch (k) {
    case msg::TaskKind::kIdle: return "idle";
    case msg::TaskKind::kExplore: return "explore";
    case msg::TaskKind::kGoto: return "goto";
    case msg::TaskKind::kStop: return "stop";
  }
  return "?";
}

}  // namespace

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t{bytes[i]} << 16) | (std::uint32_t{bytes[i + 1]} << 8) | bytes[i + 2];
    for (int k = 18; k >= 0; k -= 6) out += kAlphabet[(v >> k) & 63];
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const std::uint32_t v = (std::uint32_t{bytes[i]} << 16) | (two ? std::uint32_t{bytes[i + 1]} << 8 : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += two ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

void WebState::on_status(std::uint16_t robot, WebRobotStatus status) {
  // Only robots the fleet shows get a panel: the fleet bounds who that is.
  status_[robot] = std::move(status);
}

void WebState::on_command_result(std::uint64_t id, const WebCommand& command, std::string result) {
  for (Result& r : results_) {
    if (r.id == id) {
      r.result = std::move(result);
      return;
    }
  }
  results_.push_back({id, command, std::move(result)});
  while (results_.size() > kWebCommandHistory) results_.pop_front();
}

std::string WebState::state_json(Nanos now, const Fleet& fleet, const Fusion* fusion, const explore::TaskAllocator* explore) {
  // Rows the fleet dropped (it bounds unlisted robots) are dropped here too: ids cycled by
  // a hostile publisher cannot grow these maps.
  std::erase_if(status_, [&](const auto& kv) { return !fleet.robots().contains(kv.first); });
  std::erase_if(trails_, [&](const auto& kv) { return !fleet.robots().contains(kv.first); });
  json robots = json::array();
  msg::PoseCorrection c;
  for (const auto& [id, e] : fleet.robots()) {
    json r{{"id", id},
           {"name", e.name},
           {"mode", e.mode},
           {"presence", presence_name(e.presence)},
           {"link_age_s", mm(nanos_to_seconds(now - e.last_seen))}};
    if (const auto s = status_.find(id); s != status_.end()) {
      const WebRobotStatus& st = s->second;
      json devices = json::array();
      for (const auto& d : st.devices) devices.push_back({{"name", d.name}, {"state", d.state}, {"reason", d.reason}});
      const auto reason = static_cast<StopReason>(st.stop_reason);
      r["battery_v"] = mm(st.battery_voltage);
      r["battery_soc"] = mm(st.battery_soc);
      r["stop"] = st.stop_reason <= static_cast<std::uint8_t>(kLastStopReason) ? stop_reason_text(reason) : "unknown";
      r["stop_text"] = st.stop_text;
      r["estop"] = reason == StopReason::kEstop || reason == StopReason::kResetRequired;
      r["reset_required"] = reason == StopReason::kResetRequired;  // latched: the page offers a reset
      r["nav_state"] = st.nav_state;
      r["devices"] = std::move(devices);
      r["rt"] = {{"period_mean_us", mm(st.loop_period_mean_us)}, {"period_p99_us", mm(st.loop_period_p99_us)},
                 {"jitter_max_us", mm(st.loop_jitter_max_us)},   {"cycles", st.loop_cycles},
                 {"misses", st.deadline_misses},                 {"overflows", st.queue_overflows}};
    }
    if (fusion && fusion->correction(id, 0, &c)) {
      const Pose2& p = c.global_pose;
      r["pose"] = {{"x", mm(p.x)}, {"y", mm(p.y)}, {"theta", mm(p.theta)}};
      r["ellipse"] = ellipse({c.global_cov[0], c.global_cov[1], c.global_cov[3], c.global_cov[4]});
      std::deque<Vec2>& trail = trails_[id];
      const Vec2 here(p.x, p.y);
      if (here.allFinite() && (trail.empty() || (trail.back() - here).norm() >= kWebTrailStepM)) trail.push_back(here);
      while (trail.size() > kWebTrailPoints) trail.pop_front();
    }
    if (const auto t = trails_.find(id); t != trails_.end()) {
      json pts = json::array();
      for (const Vec2& v : t->second) pts.push_back({mm(v.x()), mm(v.y())});
      r["trail"] = std::move(pts);
    }
    if (explore) {
      if (const auto task = explore->task(id)) {
        r["task"] = {{"kind", task_kind(task->kind)},
                     {"id", task->task_id},
                     {"x", mm(task->target.x())},
                     {"y", mm(task->target.y())},
                     {"active", task->active}};
        if (task->kind == msg::TaskKind::kExplore) {
          r["task"]["gain"] = mm(task->gain);
          r["task"]["igr"] = rect(task->igr);
        }
      }
      if (const msg::Bid* bid = explore->latest_bid(id)) r["bid"] = bid_json(*bid);
    }
    robots.push_back(std::move(r));
  }
  json landmarks = json::array();
  std::size_t total = 0;
  if (fusion) {
    std::vector<msg::Landmark> all;
    fusion->landmarks(&all);
    total = all.size();
    for (std::size_t i = 0; i < all.size() && i < kWebMaxLandmarks; ++i) {
      const msg::Landmark& l = all[i];
      landmarks.push_back({{"id", l.id}, {"x", mm(l.x)}, {"y", mm(l.y)}, {"ellipse", ellipse(l.cov)}});
    }
  }
  json commands = json::array();
  for (const Result& res : results_) {
    json cmd{{"id", res.id}, {"cmd", web_command_name(res.command.kind)}, {"result", res.result}};
    if (res.command.kind == WebCommandKind::kVisit || res.command.kind == WebCommandKind::kReset) cmd["robot"] = res.command.robot;
    if (res.command.kind == WebCommandKind::kVisit) {
      cmd["x"] = mm(res.command.x);
      cmd["y"] = mm(res.command.y);
    }
    if (res.command.kind == WebCommandKind::kExplore) cmd["run"] = res.command.run;
    commands.push_back(std::move(cmd));
  }
  json exploration = nullptr;  // null: the base runs no exploration executive
  if (explore) {
    const explore::TaskAllocator& a = *explore;
    json given_up = json::array();
    const std::vector<Vec2> spots = a.given_up();
    for (std::size_t i = 0; i < spots.size() && i < kWebMaxGivenUp; ++i) given_up.push_back({mm(spots[i].x()), mm(spots[i].y())});
    exploration = {{"paused", a.paused()},
                   {"explored", a.explored()},
                   {"frontier_seen", a.frontier_seen()},
                   {"rounds", a.counters().rounds},
                   {"given_up", std::move(given_up)}};
  }
  return json{{"type", "state"},
              {"robots", std::move(robots)},
              {"landmarks", std::move(landmarks)},
              {"landmarks_total", total},
              {"explore", explore != nullptr},
              {"exploration", std::move(exploration)},
              {"commands", std::move(commands)}}
      .dump();
}

}  // namespace cairn::base
