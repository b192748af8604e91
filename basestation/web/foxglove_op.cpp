#include "basestation/web/foxglove_op.hpp"

#include <nlohmann/json.hpp>

namespace cairn::base {

namespace {

using nlohmann::json;

FoxgloveOp fail(std::string why) {
  FoxgloveOp op;
  op.error = std::move(why);
  return op;
}

// A JSON integer 0..2^32-1 (the protocol's ids are numbers; ours are uint32).
bool uint32_of(const json& j, std::uint32_t* out) {
  if (!j.is_number_integer()) return false;
  if (j.is_number_unsigned()) {
    const auto v = j.get<std::uint64_t>();
    if (v > 0xffffffffu) return false;
    *out = static_cast<std::uint32_t>(v);
    return true;
  }
  const auto v = j.get<std::int64_t>();
  if (v < 0 || v > 0xffffffffll) return false;
  *out = static_cast<std::uint32_t>(v);
  return true;
}

const json* array_field(const json& j, const char* key) {
  const auto it = j.find(key);
  return it == j.end() || !it->is_array() ? nullptr : &*it;
}

FoxgloveOp subscribe(const json& j) {
  const json* subs = array_field(j, "subscriptions");
  if (!subs || subs->empty()) return fail("subscribe: \"subscriptions\" must be a non-empty array");
  if (subs->size() > kMaxFoxgloveOpEntries)
    return fail("subscribe: more than " + std::to_string(kMaxFoxgloveOpEntries) + " subscriptions in one op");
  FoxgloveOp op;
  op.kind = FoxgloveOp::Kind::kSubscribe;
  for (const json& s : *subs) {
    FoxgloveSubscription sub;
    if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !uint32_of(s["id"], &sub.id) ||
        !uint32_of(s["channelId"], &sub.channel_id))
      return fail("subscribe: each subscription needs \"id\" and \"channelId\", integers 0..4294967295");
    op.subscribe.push_back(sub);
  }
  return op;
}

FoxgloveOp unsubscribe(const json& j) {
  const json* ids = array_field(j, "subscriptionIds");
  if (!ids || ids->empty()) return fail("unsubscribe: \"subscriptionIds\" must be a non-empty array");
  if (ids->size() > kMaxFoxgloveOpEntries)
    return fail("unsubscribe: more than " + std::to_string(kMaxFoxgloveOpEntries) + " ids in one op");
  FoxgloveOp op;
  op.kind = FoxgloveOp::Kind::kUnsubscribe;
  for (const json& id : *ids) {
    std::uint32_t v = 0;
    if (!uint32_of(id, &v)) return fail("unsubscribe: \"subscriptionIds\" must be integers 0..4294967295");
    op.unsubscribe.push_back(v);
  }
  return op;
}

}  // namespace

FoxgloveOp parse_foxglove_op(std::string_view text) {
  if (text.size() > kMaxFoxgloveOpBytes) return fail("op longer than " + std::to_string(kMaxFoxgloveOpBytes) + " bytes");
  // No exceptions: a malformed text is a discarded value. Depth is bounded by the size cap.
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return fail("not JSON");
  if (!j.is_object()) return fail("expected a JSON object");
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) return fail("missing \"op\" (a string)");
  const std::string& name = op->get_ref<const std::string&>();
  if (name == "subscribe") return subscribe(j);
  if (name == "unsubscribe") return unsubscribe(j);
  return fail("unsupported op (this server has no capabilities: subscribe and unsubscribe only)");
}

}  // namespace cairn::base
