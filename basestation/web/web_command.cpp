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

}  // namespace

WebCommandParse parse_web_command(std::string_view text) {
  if (text.size() > kMaxWebCommandBytes) return fail("command longer than " + std::to_string(kMaxWebCommandBytes) + " bytes");
  // No exceptions: a malformed text is a discarded value. Depth is bounded by the size cap.
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return fail("not JSON");
  if (!j.is_object()) return fail("expected a JSON object");
  const auto cmd = j.find("cmd");
  if (cmd == j.end() || !cmd->is_string()) return fail("missing \"cmd\" (a string)");
  const std::string& name = cmd->get_ref<const std::string&>();
  if (name != "visit") return fail("unknown command (known: visit)");
  const auto robot = j.find("robot");
  if (robot == j.end() || !robot->is_number_integer()) return fail("visit: \"robot\" must be an integer 1..65535");
  // Signed and unsigned JSON integers alike: compare as the widest of each.
  const bool in_range = robot->is_number_unsigned() ? robot->get<std::uint64_t>() >= 1 && robot->get<std::uint64_t>() <= 65535
                                                     : robot->get<std::int64_t>() >= 1 && robot->get<std::int64_t>() <= 65535;
  if (!in_range) return fail("visit: \"robot\" must be an integer 1..65535");
  WebVisit v;
  v.robot = static_cast<std::uint16_t>(robot->get<std::int64_t>());
  if (!finite_number(j, "x", &v.x) || !finite_number(j, "y", &v.y)) return fail("visit: \"x\" and \"y\" must be finite numbers (m)");
  return {v, ""};
}

}  // namespace cairn::base
