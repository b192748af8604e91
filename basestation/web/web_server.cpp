#include "basestation/web/web_server.hpp"

#include <algorithm>
#include <utility>  // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <deque>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

#include "basestation/web/foxglove_session.hpp"
#include "basestation/web/web_server_impl.hpp"
#include "common/log.hpp"

namespace cairn::base {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {

constexpr std::size_t kMaxHeaderBytes = 8 * 1024;
constexpr std::size_t kMaxBodyBytes = kMaxWebCommandBytes;
constexpr std::size_t kMaxMessageBytes = kMaxWebCommandBytes;
constexpr int kMaxConnections = 32;
constexpr std::size_t kMaxQueuedCommands = 32;  // the main loop drains them every few ms
constexpr std::size_t kMaxPendingReplies = 16;  // a client that sends faster than it reads is closed
constexpr auto kIdleTimeout = std::chrono::seconds(30);
constexpr auto kPushPeriod = std::chrono::milliseconds(50);

// Same time whatever the first differing byte: the token cannot be guessed byte by byte.
bool token_equal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = static_cast<unsigned char>(d | (a[i] ^ b[i]));
  return d == 0;
}

std::string_view query_token(std::string_view query) {
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view part = query.substr(0, amp);
    if (part.starts_with("token=")) return part.substr(6);
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return {};
}

std::string inline_script(std::string_view html, std::string_view js) {
  constexpr std::string_view kTag = "<script src=\"app.js\"></script>";
  std::string page(html);
  const std::size_t at = page.find(kTag);
  if (at == std::string::npos) throw std::runtime_error("web view: the page does not load app.js");
  page.replace(at, kTag.size(), "<script>\n" + std::string(js) + "</script>");
  return page;
}

}  // namespace

WebServer::Impl::Impl(WebServerOptions o) : options(std::move(o)), page(inline_script(options.index_html, options.app_js)) {}

bool WebServer::Impl::authorised(const http::request<http::string_body>& req) const {
  const std::string_view target(req.target().data(), req.target().size());
  const std::size_t q = target.find('?');
  if (q != std::string_view::npos && token_equal(query_token(target.substr(q + 1)), options.token)) return true;
  const auto h = req.find("X-Cairn-Token");
  if (h != req.end() && token_equal(std::string_view(h->value().data(), h->value().size()), options.token)) return true;
  const auto a = req.find(http::field::authorization);
  if (a != req.end()) {
    const std::string_view v(a->value().data(), a->value().size());
    if (v.starts_with("Bearer ") && token_equal(v.substr(7), options.token)) return true;
  }
  return false;
}

std::string WebServer::Impl::enqueue(std::string_view text) {
  const WebCommandParse p = parse_web_command(text);
  if (!p.command) {
    ++counters.commands_refused;
    return nlohmann::json{{"type", "reply"}, {"ok", false}, {"error", p.error}}.dump();
  }
  std::uint64_t id = 0;
  {
    const std::lock_guard lock(mu);
    // An E-STOP ALL is never refused for a full queue: it takes the one slot beyond the cap,
    // and while one waits another is the same command (its id is the answer).
    const bool estop = p.command->kind == WebCommandKind::kEstopAll;
    const auto waiting = std::find_if(commands.begin(), commands.end(),
                                      [](const QueuedWebCommand& c) { return c.command.kind == WebCommandKind::kEstopAll; });
    if (estop && waiting != commands.end()) {
      id = waiting->id;
    } else if (commands.size() < kMaxQueuedCommands || estop) {
      id = next_command_id++;
      commands.push_back({id, *p.command});
    }
  }
  if (id == 0) {
    ++counters.queue_full;
    return nlohmann::json{{"type", "reply"}, {"ok", false}, {"error", "busy: too many commands waiting"}}.dump();
  }
  ++counters.commands_queued;
  return nlohmann::json{{"type", "reply"}, {"ok", true}, {"id", id}, {"status", "queued"}}.dump();
}

namespace {

using Impl = WebServer::Impl;

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Impl* server, ConnectionSlot slot)
      : ws_(std::move(socket)), timer_(ws_.get_executor()), server_(server), slot_(std::move(slot)) {}

  void run(const http::request<http::string_body>& req) {
    beast::get_lowest_layer(ws_).expires_never();  // the websocket's own timeouts from here
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(kMaxMessageBytes);
    ws_.async_accept(req, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    read();
    tick(beast::error_code{});
  }
  void read() { ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this())); }
  void on_read(beast::error_code ec, std::size_t) {
    if (ec) {
      if (ec == websocket::error::message_too_big) ++server_->counters.bad_requests;
      stop();
      return;
    }
    const std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    if (outbox_.size() >= kMaxPendingReplies) {
      ++server_->counters.bad_requests;
      stop();
      return;
    }
    outbox_.push_back(std::make_shared<const std::string>(server_->enqueue(text)));
    write_next();
    read();
  }
  void tick(beast::error_code ec) {
    if (ec || closed_) return;
    push_latest();
    timer_.expires_after(kPushPeriod);
    timer_.async_wait(beast::bind_front_handler(&WsSession::tick, shared_from_this()));
  }
  // Only the newest state and map go out; a slow client skips the ones in between.
  void push_latest() {
    if (writing_ || !outbox_.empty()) return;
    const Impl::Latest l = server_->latest();
    if (l.map && l.map->version != sent_map_) {  // the tiles this socket has not seen
      outbox_.push_back(std::make_shared<const std::string>(l.map->message_since(sent_map_)));
      sent_map_ = l.map->version;
    }
    if (l.state && l.state_version != sent_state_) {
      sent_state_ = l.state_version;
      outbox_.push_back(l.state);
    }
    write_next();
  }
  void write_next() {
    if (writing_ || outbox_.empty() || closed_) return;
    writing_ = true;
    ws_.text(true);
    ws_.async_write(asio::buffer(*outbox_.front()), beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }
  void on_write(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (ec) {
      stop();
      return;
    }
    outbox_.pop_front();
    ++server_->counters.messages_sent;
    write_next();
  }
  void stop() {
    closed_ = true;
    timer_.cancel();
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  asio::steady_timer timer_;
  Impl* server_;
  ConnectionSlot slot_;
  std::deque<std::shared_ptr<const std::string>> outbox_;
  bool writing_ = false, closed_ = false;
  std::uint64_t sent_state_ = 0, sent_map_ = 0;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Impl* server, ConnectionSlot slot)
      : stream_(std::move(socket)), buffer_(kMaxHeaderBytes + kMaxBodyBytes), server_(server), slot_(std::move(slot)) {}

  void read() {
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(kMaxBodyBytes);
    stream_.expires_after(kIdleTimeout);
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

 private:
  using Response = http::response<http::string_body>;

  void on_read(beast::error_code ec, std::size_t) {
    if (ec) {
      // A closed or idle connection is not an error; anything else (too long, malformed) is.
      if (ec != http::error::end_of_stream && ec != beast::error::timeout && ec != asio::error::operation_aborted &&
          ec != asio::error::connection_reset)
        ++server_->counters.bad_requests;
      beast::error_code ignored;
      stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
      return;
    }
    ++server_->counters.requests;
    http::request<http::string_body> req = parser_->release();
    if (websocket::is_upgrade(req) && server_->authorised(req)) {
      const std::string_view p = path(req);
      if (offers_foxglove_subprotocol(req) && (p == "/" || p == "/foxglove")) {
        start_foxglove_session(stream_.release_socket(), server_, std::move(slot_), req);
        return;
      }
      if (p == "/ws") {
        std::make_shared<WsSession>(stream_.release_socket(), server_, std::move(slot_))->run(req);
        return;
      }
    }
    send(handle(req));
  }

  static std::string_view path(const http::request<http::string_body>& req) {
    const std::string_view t(req.target().data(), req.target().size());
    return t.substr(0, t.find('?'));
  }

  Response reply(const http::request<http::string_body>& req, http::status status, std::string body,
                 std::string_view type) const {
    Response r{status, req.version()};
    r.set(http::field::server, "cairn-base");
    r.set(http::field::content_type, std::string(type));
    r.set(http::field::cache_control, "no-store");
    r.keep_alive(req.keep_alive());
    r.body() = std::move(body);
    r.prepare_payload();
    return r;
  }

  Response handle(const http::request<http::string_body>& req) {
    if (!server_->authorised(req)) {
      ++server_->counters.unauthorized;
      Response r = reply(req, http::status::unauthorized,
                         "401 Unauthorized: this Cairn base's web view needs its token (?token=... from [web] token)\n",
                         "text/plain; charset=utf-8");
      r.set(http::field::www_authenticate, "Bearer");
      return r;
    }
    const std::string_view p = path(req);
    const bool get = req.method() == http::verb::get;
    if (get && (p == "/" || p == "/index.html")) return reply(req, http::status::ok, server_->page, "text/html; charset=utf-8");
    if (get && (p == "/api/state" || p == "/api/map")) {
      const Impl::Latest l = server_->latest();
      std::string doc = p == "/api/state" ? (l.state ? *l.state : "{}") : (l.map ? l.map->message_since(0) : "{}");
      return reply(req, http::status::ok, std::move(doc), "application/json");
    }
    if (p == "/api/command") {
      if (req.method() != http::verb::post) return reply(req, http::status::method_not_allowed, "POST a command\n", "text/plain");
      std::string r = server_->enqueue(req.body());
      const bool ok = r.find("\"ok\":true") != std::string::npos;
      return reply(req, ok ? http::status::accepted : http::status::bad_request, std::move(r), "application/json");
    }
    ++server_->counters.bad_requests;
    return reply(req, http::status::not_found, "404 Not Found\n", "text/plain");
  }

  void send(Response res) {
    auto sp = std::make_shared<Response>(std::move(res));
    http::async_write(stream_, *sp, [self = shared_from_this(), sp](beast::error_code ec, std::size_t) {
      if (ec) return;
      if (sp->need_eof()) {
        beast::error_code ignored;
        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
        return;
      }
      self->read();
    });
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  Impl* server_;
  ConnectionSlot slot_;
};

void accept(Impl* s) {
  s->acceptor.async_accept(asio::make_strand(s->ioc), [s](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) {
      if (s->connections >= kMaxConnections) {
        ++s->counters.connections_refused;  // closed by the socket's destructor
      } else {
        std::make_shared<HttpSession>(std::move(socket), s, ConnectionSlot(s))->read();
      }
    }
    accept(s);
  });
}

}  // namespace

WebServer::WebServer(WebServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {
  beast::error_code ec;
  const asio::ip::address addr = asio::ip::make_address(impl_->options.listen, ec);
  const std::string where = impl_->options.listen + ":" + std::to_string(impl_->options.port);
  if (ec) throw std::runtime_error("web view: bad listen address " + where);
  const tcp::endpoint ep(addr, impl_->options.port);
  auto& a = impl_->acceptor;
  if (!a.open(ep.protocol(), ec) && !a.set_option(asio::socket_base::reuse_address(true), ec) && !a.bind(ep, ec) &&
      !a.listen(asio::socket_base::max_listen_connections, ec)) {
    port_ = a.local_endpoint().port();
  } else {
    throw std::runtime_error("web view: cannot listen on " + where + ": " + ec.message());
  }
  accept(impl_.get());
  thread_ = std::thread([s = impl_.get()] {
    for (;;) {
      try {
        s->ioc.run();
        return;
      } catch (const std::exception& e) {  // a handler's bug must not end the base
        CAIRN_LOG_ERROR("web", "web view: {}", e.what());
      }
    }
  });
}

WebServer::~WebServer() {
  impl_->ioc.stop();
  thread_.join();
}

void WebServer::publish_state(std::shared_ptr<const std::string> json) {
  const std::lock_guard lock(impl_->mu);
  impl_->state = std::move(json);
  ++impl_->state_version;
}

void WebServer::publish_map(std::shared_ptr<const WebMapSnapshot> map) {
  const std::lock_guard lock(impl_->mu);
  impl_->map = std::move(map);
}

void WebServer::publish_foxglove(std::shared_ptr<const FoxgloveSnapshot> snapshot) {
  const std::lock_guard lock(impl_->mu);
  impl_->foxglove = std::move(snapshot);
}

std::vector<QueuedWebCommand> WebServer::take_commands() {
  std::vector<QueuedWebCommand> out;
  const std::lock_guard lock(impl_->mu);
  out.assign(impl_->commands.begin(), impl_->commands.end());
  impl_->commands.clear();
  return out;
}

const WebCounters& WebServer::counters() const { return impl_->counters; }

}  // namespace cairn::base
