// The web server's Foxglove WebSocket protocol, with our own Beast client on loopback
// (tests/basestation/foxglove_client.hpp), checked against the protocol's spec: the token
// and the subprotocol; serverInfo then advertise with JSON schemas; subscribe -> binary
// messageData frames with the subscription id and the published map; unsubscribe stops
// them; a malformed op gets a status error and the socket goes on; a client that never
// reads is skipped, then closed, and nothing queues for it.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "basestation/web/foxglove_channels.hpp"
#include "basestation/web/foxglove_op.hpp"
#include "basestation/web/web_server.hpp"
#include "tests/basestation/foxglove_client.hpp"
#include "tests/support/eventually.hpp"

namespace cairn::base {
namespace {

using nlohmann::json;
using test::FoxgloveClient;
using beast_error = test::beast::error_code;

constexpr const char* kToken = "token-for-the-test-0123";
const std::string kQ = std::string("/?token=") + kToken;

WebServerOptions options() {
  WebServerOptions o;
  o.token = kToken;
  o.index_html = "<html><script src=\"app.js\"></script></html>";
  o.app_js = "let page = 1;";
  return o;
}

beast_error websocket_declined() { return test::websocket::error::upgrade_declined; }

using testing::eventually;

// A 7 x 5 map at 0.1 m from (-1, 2): cell (3, 2) an obstacle, (0, 0) clear, the rest unknown.
ClassGrid small_map() {
  ClassGrid g;
  g.geometry.resolution = 0.1;
  g.geometry.origin_x = -1.0;
  g.geometry.origin_y = 2.0;
  g.geometry.width = 7;
  g.geometry.height = 5;
  g.cells.assign(g.geometry.cells(), Cell::kUnknown);
  g.at(3, 2) = Cell::kObstacle;
  g.at(0, 0) = Cell::kClear;
  return g;
}

struct Publisher {
  Fleet fleet{3 * kNanosPerSecond, nullptr, {}};
  FoxgloveChannels channels;
  std::uint64_t stamp = 1'700'000'000'000'000'000u;
  void publish(WebServer& server, const std::string& state = R"({"type":"state"})") {
    server.publish_foxglove(channels.snapshot(fleet, nullptr, std::make_shared<const std::string>(state), ++stamp));
  }
};

std::uint32_t channel_id(const json& advertise, const std::string& topic) {
  for (const json& c : advertise["channels"])
    if (c["topic"] == topic) return c["id"].get<std::uint32_t>();
  ADD_FAILURE() << "no channel " << topic << " in " << advertise.dump();
  return 0;
}

std::string subscribe(std::uint32_t id, std::uint32_t channel) {
  return json{{"op", "subscribe"}, {"subscriptions", {{{"id", id}, {"channelId", channel}}}}}.dump();
}

TEST(FoxgloveServer, TheUpgradeNeedsTheTokenAndAcceptsTheSubprotocol) {
  WebServer server(options());
  {
    FoxgloveClient no_token(server.port(), "/");
    EXPECT_EQ(no_token.error, websocket_declined()) << no_token.error.message();
  }
  {
    FoxgloveClient wrong(server.port(), "/?token=token-for-the-test-0124");
    EXPECT_EQ(wrong.error, websocket_declined());
  }
  EXPECT_EQ(server.counters().unauthorized.load(), 2u);  // both answered 401
  EXPECT_EQ(server.counters().foxglove_sessions.load(), 0u);
  {  // The token but no subprotocol on "/": that is the page, not a socket.
    FoxgloveClient plain(server.port(), kQ, "");
    EXPECT_EQ(plain.error, websocket_declined());
  }
  FoxgloveClient ok(server.port(), kQ, "something.else, foxglove.websocket.v1");
  ASSERT_FALSE(ok.error) << ok.error.message();
  EXPECT_EQ(ok.accepted_subprotocol, "foxglove.websocket.v1");
  const auto info = ok.next_op("serverInfo");
  ASSERT_TRUE(info);
  EXPECT_EQ((*info)["name"], "cairn-base");
  EXPECT_TRUE((*info)["capabilities"].is_array());
  const auto adv = ok.next_op("advertise", nullptr, 0);  // at once, even before the first snapshot: no channels yet
  ASSERT_TRUE(adv);
  EXPECT_TRUE((*adv)["channels"].empty());
  FoxgloveClient on_foxglove_path(server.port(), "/foxglove?token=" + std::string(kToken));
  EXPECT_FALSE(on_foxglove_path.error) << on_foxglove_path.error.message();
  EXPECT_TRUE(eventually([&] { return server.counters().foxglove_sessions.load() == 2; }));
}

TEST(FoxgloveServer, ServerInfoThenAdvertiseWithJsonSchemas) {
  WebServer server(options());
  Publisher pub;
  pub.publish(server);
  FoxgloveClient c(server.port(), kQ);
  ASSERT_FALSE(c.error) << c.error.message();
  const std::optional<test::WsMessage> first = c.read();
  ASSERT_TRUE(first);
  EXPECT_EQ(json::parse(first->data)["op"], "serverInfo");  // always first
  const auto adv = c.next_op("advertise");
  ASSERT_TRUE(adv);
  std::set<std::string> topics;
  for (const json& ch : (*adv)["channels"]) {
    topics.insert(ch["topic"].get<std::string>());
    EXPECT_EQ(ch["encoding"], "json");
    EXPECT_EQ(ch["schemaEncoding"], "jsonschema");
    const json schema = json::parse(ch["schema"].get<std::string>(), nullptr, false);
    ASSERT_TRUE(schema.is_object()) << ch["topic"];
    EXPECT_EQ(schema["type"], "object");
    EXPECT_EQ(schema["title"], ch["schemaName"]);  // foxglove.Grid's schema is titled foxglove.Grid
  }
  EXPECT_EQ(topics, (std::set<std::string>{"/map", "/cairn/scene", "/cairn/robots/poses", "/cairn/state"}));
  EXPECT_EQ((*adv)["channels"][0]["schemaName"], "foxglove.Grid");
  const json grid = json::parse((*adv)["channels"][0]["schema"].get<std::string>());
  EXPECT_EQ(grid["properties"]["data"]["contentEncoding"], "base64");
}

TEST(FoxgloveServer, ASubscriptionGetsTheMapAndAnUnsubscribeStopsIt) {
  WebServer server(options());
  Publisher pub;
  pub.channels.set_map(small_map(), 42);
  pub.publish(server);
  FoxgloveClient c(server.port(), kQ);
  const auto adv = c.next_op("advertise");
  ASSERT_TRUE(adv);
  const std::uint32_t map = channel_id(*adv, "/map");
  c.send_text(subscribe(17, map));
  const auto frame = c.next_message_data();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->subscription, 17u);
  EXPECT_EQ(frame->stamp_ns, 42u);
  const json g = json::parse(frame->payload);
  EXPECT_EQ(g["frame_id"], "map");
  EXPECT_EQ(g["column_count"], 7);
  EXPECT_EQ(g["cell_stride"], 4);
  EXPECT_EQ(g["row_stride"], 28);
  EXPECT_DOUBLE_EQ(g["cell_size"]["x"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(g["pose"]["position"]["x"].get<double>(), -1.0);
  EXPECT_DOUBLE_EQ(g["pose"]["position"]["y"].get<double>(), 2.0);
  const std::vector<std::uint8_t> data = test::unbase64(g["data"].get<std::string>());
  ASSERT_EQ(data.size(), 7u * 5u * 4u);  // 5 rows
  auto cell = [&](int i, int j) {
    const std::size_t k = static_cast<std::size_t>(j) * 28 + static_cast<std::size_t>(i) * 4;
    return std::vector<int>{data[k], data[k + 1], data[k + 2], data[k + 3]};
  };
  EXPECT_EQ(cell(3, 2), (std::vector<int>{0, 0, 0, 255}));        // the obstacle, black
  EXPECT_EQ(cell(0, 0), (std::vector<int>{255, 255, 255, 255}));  // clear, white (row 0 at the bottom)
  EXPECT_EQ(cell(6, 4), (std::vector<int>{190, 190, 190, 128}));  // unknown, grey

  // A new map and a new robot channel: the client is told of the channel and gets the map.
  ClassGrid second = small_map();
  second.at(6, 4) = Cell::kObstacle;
  pub.channels.set_map(second, 43);
  pub.publish(server);
  const auto frame2 = c.next_message_data();
  ASSERT_TRUE(frame2);
  EXPECT_EQ(frame2->stamp_ns, 43u);

  // Unsubscribed: the status for a malformed op after it proves the server read it; then
  // a new map published with a fourth new state, seen by the session (the state channel's
  // data reaches a second subscription), brings no map frame.
  c.send_text(R"({"op":"unsubscribe","subscriptionIds":[17]})");
  c.send_text("marker 1");
  ASSERT_TRUE(c.next_op("status"));
  const std::uint32_t state = channel_id(*adv, "/cairn/state");
  c.send_text(subscribe(18, state));
  const auto state_frame = c.next_message_data();
  ASSERT_TRUE(state_frame);
  EXPECT_EQ(state_frame->subscription, 18u);
  pub.channels.set_map(small_map(), 44);
  pub.publish(server, R"({"type":"state","n":2})");
  for (;;) {  // until the new state: no map frame may come before it (both go out together)
    const auto f = c.next_message_data();
    ASSERT_TRUE(f);
    ASSERT_EQ(f->subscription, 18u) << "a frame for the unsubscribed map";
    if (f->payload == R"({"type":"state","n":2})") break;
  }
  c.send_text("marker 2");  // and nothing after it either, up to the status
  std::vector<test::WsMessage> between;
  ASSERT_TRUE(c.next_op("status", &between));
  for (const auto& m : between) EXPECT_NE(test::message_data(m).value_or(test::MessageData{}).subscription, 17u);
}

// A snapshot of hand-made channels: ids as given, each with a payload of its own version.
std::shared_ptr<const FoxgloveSnapshot> channels(std::vector<std::uint32_t> ids, std::uint64_t version) {
  auto s = std::make_shared<FoxgloveSnapshot>();
  for (const std::uint32_t id : ids)
    s->channels.push_back({id, "/t" + std::to_string(id), "cairn.Test", R"({"type":"object"})",
                           std::make_shared<const std::string>("{\"v\":" + std::to_string(version) + "}"), version, version});
  return s;
}

TEST(FoxgloveServer, ChannelsThatGoAreUnadvertisedAndTheirSubscriptionsEnd) {
  WebServer server(options());
  server.publish_foxglove(channels({1, 7}, 1));
  FoxgloveClient c(server.port(), kQ);
  const auto adv = c.next_op("advertise");
  ASSERT_TRUE(adv);
  EXPECT_EQ((*adv)["channels"].size(), 2u);
  c.send_text(subscribe(3, 7));
  const auto f = c.next_message_data();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->payload, R"({"v":1})");
  server.publish_foxglove(channels({1}, 2));
  const auto gone = c.next_op("unadvertise");
  ASSERT_TRUE(gone);
  EXPECT_EQ((*gone)["channelIds"], json::array({7}));
  c.send_text(R"({"op":"unsubscribe","subscriptionIds":[3]})");  // ended with its channel
  auto s = c.next_op("status");
  ASSERT_TRUE(s);
  EXPECT_EQ((*s)["message"], "unsubscribe: unknown subscription id 3");
  c.send_text(subscribe(3, 7));
  s = c.next_op("status");
  ASSERT_TRUE(s);
  EXPECT_EQ((*s)["message"], "subscribe: unknown channel id 7");
  server.publish_foxglove(channels({1, 7}, 3));  // back: advertised again, the id free for reuse
  const auto back = c.next_op("advertise");
  ASSERT_TRUE(back);
  ASSERT_EQ((*back)["channels"].size(), 1u);
  EXPECT_EQ((*back)["channels"][0]["id"], 7);
  c.send_text(subscribe(3, 7));
  const auto again = c.next_message_data();
  ASSERT_TRUE(again);
  EXPECT_EQ(again->subscription, 3u);
  EXPECT_EQ(again->payload, R"({"v":3})");
}

TEST(FoxgloveServer, MalformedOpsGetAStatusErrorAndTheSocketGoesOn) {
  WebServer server(options());
  Publisher pub;
  pub.publish(server);
  FoxgloveClient c(server.port(), kQ);
  const auto adv = c.next_op("advertise");
  ASSERT_TRUE(adv);
  auto error_for = [&](const std::string& text, bool binary = false) {
    if (binary) c.send_binary(text);
    else c.send_text(text);
    const auto s = c.next_op("status");
    if (!s) return std::string("(no status)");
    EXPECT_EQ((*s)["level"], 2);
    return (*s)["message"].get<std::string>();
  };
  EXPECT_EQ(error_for("{not json"), "not JSON");
  EXPECT_EQ(error_for(subscribe(1, 999)), "subscribe: unknown channel id 999");
  EXPECT_EQ(error_for(R"({"op":"unsubscribe","subscriptionIds":[5]})"), "unsubscribe: unknown subscription id 5");
  EXPECT_EQ(error_for(std::string("\x02\x00\x00\x00", 4), true),
            "binary messages are not accepted (this server has no clientPublish or services)");
  const std::uint32_t state = channel_id(*adv, "/cairn/state");
  c.send_text(subscribe(1, state));
  EXPECT_EQ(error_for(subscribe(1, channel_id(*adv, "/map"))), "subscribe: subscription id 1 already in use");
  EXPECT_EQ(error_for(subscribe(2, state)), "subscribe: channel 4 already subscribed");
  EXPECT_EQ(server.counters().foxglove_ops_refused.load(), 6u);
  // Still usable: the state arrives on subscription 1.
  pub.publish(server, R"({"type":"state","after":"errors"})");
  for (;;) {
    const auto f = c.next_message_data();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->subscription, 1u);
    if (f->payload == R"({"type":"state","after":"errors"})") break;
  }
  // An op over the size cap closes the connection, counted.
  c.send_text(std::string(kMaxFoxgloveOpBytes + 1, ' '));
  for (int i = 0; i < 100 && c.read(); ++i) {  // until the server's close arrives (the client answers it)
  }
  EXPECT_TRUE(eventually([&] { return server.counters().bad_requests.load() == 1; }));
}

TEST(FoxgloveServer, AClientThatNeverReadsIsSkippedThenClosed) {
  WebServerOptions o = options();
  o.foxglove_stall_limit = std::chrono::milliseconds(2000);
  WebServer server(o);
  Publisher pub;
  ClassGrid big;  // 512 x 512 cells: 1 MiB of RGBA, ~1.4 MB of JSON a message
  big.geometry.width = big.geometry.height = 512;
  big.cells.assign(big.geometry.cells(), Cell::kClear);
  pub.channels.set_map(big, 1);
  pub.publish(server);
  FoxgloveClient sleeper(server.port(), kQ);
  const auto adv = sleeper.next_op("advertise");
  ASSERT_TRUE(adv);
  sleeper.send_text(subscribe(1, channel_id(*adv, "/map")));  // and never reads again
  int published = 1;
  while (server.counters().foxglove_skipped.load() == 0 && published < 200) {
    big.at(published % 512, 0) = Cell::kObstacle;
    pub.channels.set_map(big, static_cast<std::uint64_t>(++published));
    pub.publish(server);
    const std::uint64_t sent = server.counters().foxglove_messages_sent.load();
    eventually([&] { return server.counters().foxglove_skipped.load() > 0 || server.counters().foxglove_messages_sent.load() > sent; },
               std::chrono::milliseconds(100));
  }
  EXPECT_GT(server.counters().foxglove_skipped.load(), 0u) << published << " maps published";
  EXPECT_LT(server.counters().foxglove_messages_sent.load(), static_cast<std::uint64_t>(published));
  // The stalled write closes it; another client is served meanwhile and after.
  FoxgloveClient reader(server.port(), kQ);
  ASSERT_TRUE(reader.next_op("advertise"));
  EXPECT_TRUE(eventually([&] { return server.counters().foxglove_dropped.load() == 1; }));
  reader.send_text(subscribe(9, channel_id(*adv, "/map")));
  const auto f = reader.next_message_data();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->subscription, 9u);
  EXPECT_EQ(f->stamp_ns, static_cast<std::uint64_t>(published));  // the newest map, not a backlog
}

}  // namespace
}  // namespace cairn::base
