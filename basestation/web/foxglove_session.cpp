#include "basestation/web/foxglove_session.hpp"

#include <utility>  // before Boost 1.74's asio, which uses std::exchange without it

#include <array>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <algorithm>
#include <map>
#include <set>
#include <nlohmann/json.hpp>

#include "basestation/web/foxglove_op.hpp"

namespace cairn::base {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using nlohmann::json;

namespace {

constexpr auto kPushPeriod = std::chrono::milliseconds(50);
constexpr std::size_t kMaxPendingReplies = 16;  // a client that sends faster than it reads is closed
constexpr std::uint8_t kMessageDataOpcode = 0x01;
enum StatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// opcode, subscription id (uint32 LE), receive timestamp (uint64 LE, ns): the payload follows.
std::string message_data_head(std::uint32_t subscription, std::uint64_t stamp_ns) {
  std::string h(13, '\0');
  h[0] = static_cast<char>(kMessageDataOpcode);
  for (int i = 0; i < 4; ++i) h[1 + i] = static_cast<char>((subscription >> (8 * i)) & 0xff);
  for (int i = 0; i < 8; ++i) h[5 + i] = static_cast<char>((stamp_ns >> (8 * i)) & 0xff);
  return h;
}

std::string status(int level, const std::string& message) {
  return json{{"op", "status"}, {"level", level}, {"message", message}}.dump();
}

class FoxgloveSession : public std::enable_shared_from_this<FoxgloveSession> {
 public:
  FoxgloveSession(tcp::socket&& socket, WebServer::Impl* server, ConnectionSlot slot)
      : ws_(std::move(socket)), timer_(ws_.get_executor()), server_(server), slot_(std::move(slot)) {}

  void run(const http::request<http::string_body>& req) {
    beast::get_lowest_layer(ws_).expires_never();  // the websocket's own timeouts from here
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, std::string(kFoxgloveSubprotocol));
      res.set(http::field::server, "cairn-base");
    }));
    ws_.read_message_max(kMaxFoxgloveOpBytes);
    ws_.async_accept(req, beast::bind_front_handler(&FoxgloveSession::on_accept, shared_from_this()));
  }

 private:
  struct Outgoing {
    std::string head;                           // messageData: the 13-byte header; text: empty
    std::shared_ptr<const std::string> body;    // the JSON text or the message payload
    bool binary = false, reply = false;         // reply: counts under kMaxPendingReplies
  };

  void on_accept(beast::error_code ec) {
    if (ec) return;
    ++server_->counters.foxglove_sessions;
    send_text(json{{"op", "serverInfo"},
                   {"name", "cairn-base"},
                   {"capabilities", json::array()},
                   {"metadata", {{"frame", "map"}, {"docs", "docs/web-view.md"}}}}
                  .dump(),
              false);
    // The spec: at least one advertise on connect, even before the main loop's first snapshot.
    if (!server_->latest_foxglove()) send_text(R"({"channels":[],"op":"advertise"})", false);
    read();
    tick(beast::error_code{});
  }

  void read() { ws_.async_read(buffer_, beast::bind_front_handler(&FoxgloveSession::on_read, shared_from_this())); }

  void on_read(beast::error_code ec, std::size_t) {
    if (ec) {
      if (ec == websocket::error::message_too_big) ++server_->counters.bad_requests;
      stop();
      return;
    }
    const bool text = ws_.got_text();
    const std::string in = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    if (pending_replies_ >= kMaxPendingReplies) {
      ++server_->counters.bad_requests;
      stop();
      return;
    }
    if (!text) {
      refuse("binary messages are not accepted (this server has no clientPublish or services)");
    } else {
      const FoxgloveOp op = parse_foxglove_op(in);
      if (op.kind == FoxgloveOp::Kind::kSubscribe) subscribe(op.subscribe);
      else if (op.kind == FoxgloveOp::Kind::kUnsubscribe) unsubscribe(op.unsubscribe);
      else refuse(op.error);
    }
    push_latest();  // a new subscription gets the newest message now, not at the next tick
    read();
  }

  void refuse(const std::string& why) {
    ++server_->counters.foxglove_ops_refused;
    send_text(status(kError, why), true);
  }

  void subscribe(const std::vector<FoxgloveSubscription>& subs) {
    std::string problems;
    for (const FoxgloveSubscription& s : subs) {
      std::string why;
      if (!advertised_.contains(s.channel_id)) why = "unknown channel id " + std::to_string(s.channel_id);
      else if (subs_.contains(s.id)) why = "subscription id " + std::to_string(s.id) + " already in use";
      else if (by_channel_.contains(s.channel_id)) why = "channel " + std::to_string(s.channel_id) + " already subscribed";
      else if (subs_.size() >= kMaxFoxgloveSubscriptions) why = "more than " + std::to_string(kMaxFoxgloveSubscriptions) + " subscriptions";
      if (!why.empty()) {
        problems += (problems.empty() ? "" : "; ") + why;
        continue;
      }
      subs_[s.id] = s.channel_id;
      by_channel_[s.channel_id] = s.id;
      sent_.erase(s.channel_id);
    }
    if (!problems.empty()) refuse("subscribe: " + problems);
  }

  void unsubscribe(const std::vector<std::uint32_t>& ids) {
    std::string problems;
    for (const std::uint32_t id : ids) {
      const auto it = subs_.find(id);
      if (it == subs_.end()) {
        problems += (problems.empty() ? "" : "; ") + ("unknown subscription id " + std::to_string(id));
        continue;
      }
      by_channel_.erase(it->second);
      sent_.erase(it->second);
      subs_.erase(it);
    }
    if (!problems.empty()) refuse("unsubscribe: " + problems);
  }

  void tick(beast::error_code ec) {
    if (ec || closed_) return;
    if (writing_ && std::chrono::steady_clock::now() - write_started_ > server_->options.foxglove_stall_limit) {
      ++server_->counters.foxglove_dropped;  // it has not read for that long: it is gone or hopelessly slow
      stop();
      return;
    }
    push_latest();
    timer_.expires_after(kPushPeriod);
    timer_.async_wait(beast::bind_front_handler(&FoxgloveSession::tick, shared_from_this()));
  }

  // The channel list first (advertise / unadvertise against what this client was told),
  // then the newest message of each subscribed channel it has not had. Nothing is queued
  // behind a write in progress: the messages published meanwhile are skipped, counted.
  void push_latest() {
    const std::shared_ptr<const FoxgloveSnapshot> snap = server_->latest_foxglove();
    if (writing_ || !outbox_.empty()) {
      if (snap && has_news(*snap)) ++server_->counters.foxglove_skipped;
      return;
    }
    if (!snap) return;
    if (snap != seen_) {
      seen_ = snap;
      advertise(*snap);
    }
    for (const FoxgloveChannel& c : snap->channels) {
      const auto sub = by_channel_.find(c.id);
      if (sub == by_channel_.end() || !c.payload) continue;
      auto& sent = sent_[c.id];
      if (sent == c.version) continue;
      sent = c.version;
      outbox_.push_back({message_data_head(sub->second, c.stamp_ns), c.payload, true, false});
    }
    write_next();
  }

  bool has_news(const FoxgloveSnapshot& snap) const {
    for (const FoxgloveChannel& c : snap.channels) {
      const auto s = sent_.find(c.id);
      if (c.payload && by_channel_.contains(c.id) && (s == sent_.end() || s->second != c.version)) return true;
    }
    return false;
  }

  void advertise(const FoxgloveSnapshot& snap) {
    json gone = json::array();
    for (auto it = advertised_.begin(); it != advertised_.end();) {
      const bool still = std::any_of(snap.channels.begin(), snap.channels.end(), [&](const FoxgloveChannel& c) { return c.id == *it; });
      if (still) {
        ++it;
        continue;
      }
      gone.push_back(*it);
      if (const auto sub = by_channel_.find(*it); sub != by_channel_.end()) {
        subs_.erase(sub->second);
        by_channel_.erase(sub);
      }
      sent_.erase(*it);
      it = advertised_.erase(it);
    }
    if (!gone.empty()) send_text(json{{"op", "unadvertise"}, {"channelIds", std::move(gone)}}.dump(), false);
    json added = json::array();
    for (const FoxgloveChannel& c : snap.channels) {
      if (advertised_.contains(c.id)) continue;
      advertised_.insert(c.id);
      added.push_back({{"id", c.id},
                       {"topic", c.topic},
                       {"encoding", "json"},
                       {"schemaName", c.schema_name},
                       {"schema", c.schema},
                       {"schemaEncoding", "jsonschema"}});
    }
    if (!added.empty()) send_text(json{{"op", "advertise"}, {"channels", std::move(added)}}.dump(), false);
  }

  void send_text(std::string text, bool reply) {
    if (reply) ++pending_replies_;
    outbox_.push_back({{}, std::make_shared<const std::string>(std::move(text)), false, reply});
    write_next();
  }

  void write_next() {
    if (writing_ || outbox_.empty() || closed_) return;
    writing_ = true;
    write_started_ = std::chrono::steady_clock::now();
    const Outgoing& o = outbox_.front();
    ws_.binary(o.binary);
    const std::array<asio::const_buffer, 2> buffers{asio::buffer(o.head), asio::buffer(*o.body)};
    ws_.async_write(buffers, beast::bind_front_handler(&FoxgloveSession::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (ec) {
      stop();
      return;
    }
    if (outbox_.front().reply) --pending_replies_;
    if (outbox_.front().binary) ++server_->counters.foxglove_messages_sent;
    else ++server_->counters.messages_sent;
    outbox_.pop_front();
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
  WebServer::Impl* server_;
  ConnectionSlot slot_;
  std::deque<Outgoing> outbox_;
  std::size_t pending_replies_ = 0;
  bool writing_ = false, closed_ = false;
  std::chrono::steady_clock::time_point write_started_;
  std::shared_ptr<const FoxgloveSnapshot> seen_;      // the snapshot advertised_ was brought up to
  std::set<std::uint32_t> advertised_;                 // channel ids this client was told of
  std::map<std::uint32_t, std::uint32_t> subs_;        // subscription id -> channel id
  std::map<std::uint32_t, std::uint32_t> by_channel_;  // channel id -> subscription id
  std::map<std::uint32_t, std::uint64_t> sent_;        // channel id -> version sent
};

}  // namespace

bool offers_foxglove_subprotocol(const http::request<http::string_body>& req) {
  const auto range = req.equal_range(http::field::sec_websocket_protocol);
  for (auto it = range.first; it != range.second; ++it) {
    std::string_view list(it->value().data(), it->value().size());
    while (!list.empty()) {
      const std::size_t comma = list.find(',');
      if (trim(list.substr(0, comma)) == kFoxgloveSubprotocol) return true;
      if (comma == std::string_view::npos) break;
      list.remove_prefix(comma + 1);
    }
  }
  return false;
}

void start_foxglove_session(tcp::socket&& socket, WebServer::Impl* server, ConnectionSlot slot,
                            const http::request<http::string_body>& req) {
  std::make_shared<FoxgloveSession>(std::move(socket), server, std::move(slot))->run(req);
}

}  // namespace cairn::base
