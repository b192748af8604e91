// The web view's server in process, with Beast clients on loopback: the token guards every
// route and the socket; sizes are capped and counted; the command queue is bounded; a
// socket gets the published snapshots while the publishing thread goes on (TSan build).
#include "basestation/web/web_server.hpp"
#include "tests/support/eventually.hpp"

#include <gtest/gtest.h>

#include <utility>  // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <thread>

namespace cairn::base {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

constexpr const char* kToken = "token-for-the-test-0123";

WebServerOptions options() {
  WebServerOptions o;
  o.token = kToken;
  o.index_html = "<html><script src=\"app.js\"></script></html>";
  o.app_js = "let page = 1;";
  return o;
}

struct Reply {
  int status = 0;  // 0: the server closed the connection without a reply
  std::string body;
};

Reply request(std::uint16_t port, http::verb method, const std::string& target, std::string body = "",
              std::string header_padding = "") {
  asio::io_context ioc;
  beast::tcp_stream stream(ioc);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{method, target, 11};
  req.set(http::field::host, "127.0.0.1");
  if (!header_padding.empty()) req.set("X-Padding", header_padding);
  req.body() = std::move(body);
  req.prepare_payload();
  beast::error_code ec;
  http::write(stream, req, ec);
  beast::flat_buffer buffer;
  http::response<http::string_body> res;
  http::read(stream, buffer, res, ec);
  if (ec) return {};
  return {static_cast<int>(res.result_int()), res.body()};
}

using testing::eventually;

const std::string kQ = std::string("?token=") + kToken;

TEST(WebServer, NothingWithoutTheTokenAndTheRoutesWithIt) {
  WebServer server(options());
  const std::uint16_t port = server.port();
  ASSERT_NE(port, 0);
  EXPECT_EQ(request(port, http::verb::get, "/").status, 401);
  EXPECT_EQ(request(port, http::verb::get, "/?token=token-for-the-test-0124").status, 401);
  EXPECT_EQ(request(port, http::verb::get, "/?token=token-for-the-test-012").status, 401);  // a prefix
  EXPECT_EQ(request(port, http::verb::get, "/api/state").status, 401);
  EXPECT_EQ(request(port, http::verb::post, "/api/command", R"({"cmd":"visit","robot":1,"x":0,"y":0})").status, 401);
  EXPECT_EQ(server.counters().unauthorized.load(), 5u);
  EXPECT_TRUE(server.take_commands().empty());  // never accepted without the token

  const Reply page = request(port, http::verb::get, "/" + kQ);
  EXPECT_EQ(page.status, 200);
  EXPECT_EQ(page.body, "<html><script>\nlet page = 1;</script></html>");  // app.js inline: one request, one check
  EXPECT_EQ(request(port, http::verb::get, "/api/state?x=1&token=" + std::string(kToken)).status, 200);
  EXPECT_EQ(request(port, http::verb::get, "/api/state" + kQ).body, "{}");  // nothing published yet
  server.publish_state(std::make_shared<const std::string>(R"({"type":"state"})"));
  EXPECT_EQ(request(port, http::verb::get, "/api/state" + kQ).body, R"({"type":"state"})");
  EXPECT_EQ(request(port, http::verb::get, "/nothing" + kQ).status, 404);
  EXPECT_EQ(request(port, http::verb::get, "/api/command" + kQ).status, 405);

  const Reply ok = request(port, http::verb::post, "/api/command" + kQ, R"({"cmd":"visit","robot":3,"x":1.5,"y":-2})");
  EXPECT_EQ(ok.status, 202);
  EXPECT_EQ(ok.body, R"({"id":1,"ok":true,"status":"queued","type":"reply"})");
  const Reply bad = request(port, http::verb::post, "/api/command" + kQ, R"({"cmd":"dance"})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(bad.body, R"j({"error":"unknown command (known: visit, explore, reset, estop_all)","ok":false,"type":"reply"})j");
  EXPECT_EQ(server.counters().commands_refused.load(), 1u);
  const std::vector<QueuedWebCommand> cmds = server.take_commands();
  ASSERT_EQ(cmds.size(), 1u);
  EXPECT_EQ(cmds[0].id, 1u);
  EXPECT_EQ(cmds[0].command.robot, 3);
  EXPECT_EQ(cmds[0].command.x, 1.5);
  EXPECT_EQ(cmds[0].command.y, -2.0);
}

TEST(WebServer, OversizedInputIsRefusedAndCountedAndTheServerGoesOn) {
  WebServer server(options());
  const std::uint16_t port = server.port();
  // A body over the cap and headers over the cap: the connection closes without a reply.
  EXPECT_EQ(request(port, http::verb::post, "/api/command" + kQ, std::string(kMaxWebCommandBytes + 1, 'x')).status, 0);
  EXPECT_EQ(request(port, http::verb::get, "/" + kQ, "", std::string(9000, 'p')).status, 0);
  EXPECT_TRUE(eventually([&] { return server.counters().bad_requests.load() == 2; })) << server.counters().bad_requests.load();
  EXPECT_EQ(request(port, http::verb::get, "/" + kQ).status, 200);
  EXPECT_TRUE(server.take_commands().empty());
}

TEST(WebServer, TheCommandQueueIsBounded) {
  WebServer server(options());
  int accepted = 0, busy = 0;
  for (int i = 0; i < 40; ++i) {
    const Reply r = request(server.port(), http::verb::post, "/api/command" + kQ, R"({"cmd":"visit","robot":1,"x":0,"y":0})");
    if (r.status == 202) ++accepted;
    if (r.status == 400 && r.body.find("busy") != std::string::npos) ++busy;
  }
  EXPECT_EQ(accepted, 32);
  EXPECT_EQ(busy, 8);
  EXPECT_EQ(server.counters().queue_full.load(), 8u);
  // An E-STOP ALL still goes, in the one slot beyond the cap; a second one while it waits is it.
  const Reply stop = request(server.port(), http::verb::post, "/api/command" + kQ, R"({"cmd":"estop_all"})");
  EXPECT_EQ(stop.status, 202) << stop.body;
  EXPECT_EQ(stop.body, R"({"id":33,"ok":true,"status":"queued","type":"reply"})");
  EXPECT_EQ(request(server.port(), http::verb::post, "/api/command" + kQ, R"({"cmd":"estop_all"})").body, stop.body);
  EXPECT_EQ(request(server.port(), http::verb::post, "/api/command" + kQ, R"({"cmd":"visit","robot":1,"x":0,"y":0})").status, 400);
  const auto taken = server.take_commands();
  ASSERT_EQ(taken.size(), 33u);
  EXPECT_EQ(taken.back().command.kind, WebCommandKind::kEstopAll);
  EXPECT_EQ(request(server.port(), http::verb::post, "/api/command" + kQ, R"({"cmd":"visit","robot":1,"x":0,"y":0})").status, 202);
}

TEST(WebServer, ConnectionsBeyondTheCapAreClosedAndCounted) {
  WebServer server(options());
  asio::io_context ioc;
  std::vector<tcp::socket> idle;
  for (int i = 0; i < 33; ++i) {
    idle.emplace_back(ioc);
    idle.back().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
  }
  EXPECT_TRUE(eventually([&] { return server.counters().connections_refused.load() == 1; }));
  idle.clear();  // their slots come back: a new client is served
  EXPECT_TRUE(eventually([&] { return request(server.port(), http::verb::get, "/" + kQ).status == 200; }));
}

TEST(WebServer, TheSocketNeedsTheTokenAndGetsTheSnapshotsAsTheyArePublished) {
  WebServer server(options());
  asio::io_context ioc;
  {  // Without the token: the upgrade is declined (401).
    websocket::stream<beast::tcp_stream> ws(ioc);
    beast::get_lowest_layer(ws).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
    websocket::response_type res;
    beast::error_code ec;
    ws.handshake(res, "127.0.0.1", "/ws", ec);
    EXPECT_EQ(ec, websocket::error::upgrade_declined) << ec.message();
    EXPECT_EQ(server.counters().unauthorized.load(), 1u);  // answered 401 (the browser test reads the status)
  }
  websocket::stream<beast::tcp_stream> ws(ioc);
  beast::get_lowest_layer(ws).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
  ws.handshake("127.0.0.1", "/ws" + kQ);
  {
    ClassGrid g;
    g.geometry.resolution = 0.5;
    g.geometry.width = g.geometry.height = 2;
    g.cells.assign(4, Cell::kClear);
    WebMapTiles tiles;
    server.publish_map(tiles.update(g));
  }
  // Publishing from another thread while the server sends: the latest state always arrives.
  std::thread publisher([&] {
    for (int i = 1; i <= 200; ++i) server.publish_state(std::make_shared<const std::string>("{\"n\":" + std::to_string(i) + "}"));
  });
  beast::flat_buffer buffer;
  bool map_seen = false;
  std::string last;
  while (last != "{\"n\":200}") {
    ws.read(buffer);
    const std::string text = beast::buffers_to_string(buffer.data());
    buffer.consume(buffer.size());
    if (text.rfind(R"({"type":"map","version":1,"full":true,)", 0) == 0) map_seen = true;  // the one tile, all of it
    else last = text;
  }
  publisher.join();
  EXPECT_TRUE(map_seen);
  ws.write(asio::buffer(std::string(R"({"cmd":"visit","robot":7,"x":1,"y":2})")));
  std::string reply;
  do {  // states may still be in flight before the reply
    ws.read(buffer);
    reply = beast::buffers_to_string(buffer.data());
    buffer.consume(buffer.size());
  } while (reply.find("reply") == std::string::npos);
  EXPECT_EQ(reply, R"({"id":1,"ok":true,"status":"queued","type":"reply"})");
  EXPECT_EQ(server.take_commands().at(0).command.robot, 7);
  // A message over the cap closes the socket, counted.
  beast::error_code ec;
  ws.write(asio::buffer(std::string(kMaxWebCommandBytes + 10, 'x')), ec);
  for (int i = 0; i < 100 && !ec; ++i) ws.read(buffer, ec);  // until the close arrives
  EXPECT_TRUE(ec);
  EXPECT_TRUE(eventually([&] { return server.counters().bad_requests.load() == 1; }));
}

TEST(WebServer, ABusyPortIsAClearError) {
  WebServer first(options());
  WebServerOptions o = options();
  o.port = first.port();
  try {
    WebServer second(o);
    FAIL() << "bound a port already in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen on 127.0.0.1:" + std::to_string(first.port())), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cairn::base
