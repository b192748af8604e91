// The Foxglove ops parser: subscribe and unsubscribe read exactly; anything else a clear error.
#include "basestation/web/foxglove_op.hpp"

#include <gtest/gtest.h>

#include <string>

namespace cairn::base {
namespace {

TEST(FoxgloveOp, SubscribeAndUnsubscribeAreReadExactly) {
  const FoxgloveOp s = parse_foxglove_op(R"({"op": "subscribe", "subscriptions": [{"id": 0, "channelId": 3}, {"id": 4294967295, "channelId": 1}]})");
  ASSERT_EQ(s.kind, FoxgloveOp::Kind::kSubscribe) << s.error;
  ASSERT_EQ(s.subscribe.size(), 2u);
  EXPECT_EQ(s.subscribe[0].id, 0u);
  EXPECT_EQ(s.subscribe[0].channel_id, 3u);
  EXPECT_EQ(s.subscribe[1].id, 4294967295u);
  EXPECT_EQ(s.subscribe[1].channel_id, 1u);
  EXPECT_EQ(s.error, "");
  const FoxgloveOp u = parse_foxglove_op(R"({"op":"unsubscribe","subscriptionIds":[7, 0],"extra":true})");
  ASSERT_EQ(u.kind, FoxgloveOp::Kind::kUnsubscribe) << u.error;
  EXPECT_EQ(u.unsubscribe, (std::vector<std::uint32_t>{7, 0}));
}

TEST(FoxgloveOp, EverythingElseIsAClearError) {
  const auto error = [](std::string_view text) {
    const FoxgloveOp op = parse_foxglove_op(text);
    EXPECT_EQ(op.kind, FoxgloveOp::Kind::kError) << text;
    EXPECT_TRUE(op.subscribe.empty() && op.unsubscribe.empty()) << text;
    return op.error;
  };
  EXPECT_EQ(error(""), "not JSON");
  EXPECT_EQ(error("{\"op\": \"subscribe\""), "not JSON");
  EXPECT_EQ(error("[1]"), "expected a JSON object");
  EXPECT_EQ(error(R"({"subscriptions": []})"), "missing \"op\" (a string)");
  EXPECT_EQ(error(R"({"op": 1})"), "missing \"op\" (a string)");
  EXPECT_EQ(error(R"({"op": "getParameters", "parameterNames": []})"),
            "unsupported op (this server has no capabilities: subscribe and unsubscribe only)");
  EXPECT_EQ(error(R"({"op": "advertise", "channels": []})"),
            "unsupported op (this server has no capabilities: subscribe and unsubscribe only)");
  const std::string bad_sub = "subscribe: each subscription needs \"id\" and \"channelId\", integers 0..4294967295";
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": []})"), "subscribe: \"subscriptions\" must be a non-empty array");
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": {"id": 1, "channelId": 1}})"), "subscribe: \"subscriptions\" must be a non-empty array");
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": 1}]})"), bad_sub);
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": -1, "channelId": 1}]})"), bad_sub);
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": 4294967296, "channelId": 1}]})"), bad_sub);
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": 1.5, "channelId": 1}]})"), bad_sub);
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": "1", "channelId": 1}]})"), bad_sub);
  EXPECT_EQ(error(R"({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 1}, 5]})"), bad_sub);  // all or nothing
  EXPECT_EQ(error(R"({"op": "unsubscribe", "subscriptionIds": []})"), "unsubscribe: \"subscriptionIds\" must be a non-empty array");
  EXPECT_EQ(error(R"({"op": "unsubscribe", "subscriptionIds": [1, null]})"), "unsubscribe: \"subscriptionIds\" must be integers 0..4294967295");
}

TEST(FoxgloveOp, SizesAreCapped) {
  std::string many = R"({"op":"unsubscribe","subscriptionIds":[0)";
  for (std::size_t i = 1; i < kMaxFoxgloveOpEntries; ++i) many += "," + std::to_string(i);
  EXPECT_EQ(parse_foxglove_op(many + "]}").kind, FoxgloveOp::Kind::kUnsubscribe);
  EXPECT_EQ(parse_foxglove_op(many + ",64]}").error, "unsubscribe: more than 64 ids in one op");
  std::string long_text = R"({"op":"unsubscribe","subscriptionIds":[1],"pad":")" + std::string(kMaxFoxgloveOpBytes, 'x') + "\"}";
  EXPECT_EQ(parse_foxglove_op(long_text).error, "op longer than 8192 bytes");
  std::string deep(4000, '[');  // within the size cap: nesting does not crash the parser
  EXPECT_EQ(parse_foxglove_op(deep).error, "not JSON");
}

}  // namespace
}  // namespace cairn::base
