#include "basestation/web/web_command.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

namespace cairn::base {

namespace {

WebCommandParse fail(std::string why) { return {std::nullopt, std::move(why)}; }

bool finite_number(const nlohmann::json& j, const char* key, double* out) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return false;
  *out = it->get<double>();
  return std::isfinite(*out);
}

// "robot": an integer 1..65535, signed or unsigned in JSON (compared as the widest of each).
bool robot_id(const nlohmann::json& j, std::uint16_t* out) {
  const auto robot = j.find("robot");
  if (robot == j.end() || !robot->is_number_integer()) return false;
  const bool in_range = robot->is_number_unsigned() ? robot->get<std::uint64_t>() >= 1 && robot->get<std::uint64_t>() <= 65535
                                                     : robot->get<std::int64_t>() >= 1 && robot->get<std::int64_t>() <= 65535;
  if (in_range) *out = static_cast<std::uint16_t>(robot->get<std::int64_t>());
  return in_range;
}

}  // namespace

const char* web_command_name(WebCommandKind k) {
  switch (k) {
    case WebCommandKind::kVisit: return "visit";
    case WebCommandKind::kExplore: return "explore";
    case WebCommandKind::kReset: return "reset";
    case WebCommandKind::kEstopAll: return "estop_all";
  }
  return "?";
}

WebCommandParse parse_web_command(std::string_view text) {
  if (text.size() > kMaxWebCommandBytes) return fail("command longer than " + std::to_string(kMaxWebCommandBytes) + " bytes");
  // No exceptions: a malformed text is a discarded value. Depth is bounded by the size cap.
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return fail("not JSON");
  if (!j.is_object()) return fail("expected a JSON object");
  const auto cmd = j.find("cmd");
  if (cmd == j.end() || !cmd->is_string()) return fail("missing \"cmd\" (a string)");
  const std::string& name = cmd->get_ref<const std::string&>();
  WebCommand c;
  if (name == "visit") {
    c.kind = WebCommandKind::kVisit;
    if (!robot_id(j, &c.robot)) return fail("visit: \"robot\" must be an integer 1..65535");
    if (!finite_number(j, "x", &c.x) || !finite_number(j, "y", &c.y)) return fail("visit: \"x\" and \"y\" must be finite numbers (m)");
  } else if (name == "explore") {
    c.kind = WebCommandKind::kExplore;
    const auto run = j.find("run");
    if (run == j.end() || !run->is_boolean()) return fail("explore: \"run\" must be true (start) or false (stop)");
    c.run = run->get<bool>();
  } else if (name == "reset") {
    c.kind = WebCommandKind::kReset;
    if (!robot_id(j, &c.robot)) return fail("reset: \"robot\" must be an integer 1..65535");
  } else if (name == "estop_all") {
    c.kind = WebCommandKind::kEstopAll;
  } else {
    return fail("unknown command (known: visit, explore, reset, estop_all)");
  }
  return {c, ""};
}

}  // namespace cairn::base
