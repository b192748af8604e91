// Inside the web server (web_server.cpp, foxglove_session.cpp): the state the sessions share
// on the server's thread, the snapshots under a mutex, a connection's slot under the cap.
// Not for other code: use web_server.hpp.
#pragma once

#include <utility>  // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "basestation/web/foxglove_snapshot.hpp"
#include "basestation/web/web_server.hpp"

namespace cairn::base {

struct WebServer::Impl {
  explicit Impl(WebServerOptions o);

  // Declared before ioc: the sessions its destruction destroys still count down here.
  WebServerOptions options;
  const std::string page;
  WebCounters counters;
  int connections = 0;  // io thread only (and the destructor, after the thread)

  std::mutex mu;
  std::shared_ptr<const std::string> state;  // under mu
  std::shared_ptr<const WebMapSnapshot> map;  // under mu
  std::uint64_t state_version = 0;            // under mu
  std::shared_ptr<const FoxgloveSnapshot> foxglove;  // under mu
  std::deque<QueuedWebCommand> commands;  // under mu
  std::uint64_t next_command_id = 1;      // under mu

  boost::asio::io_context ioc{1};
  boost::asio::ip::tcp::acceptor acceptor{ioc};

  struct Latest {
    std::shared_ptr<const std::string> state;
    std::shared_ptr<const WebMapSnapshot> map;
    std::uint64_t state_version = 0;
  };
  Latest latest() {
    const std::lock_guard lock(mu);
    return {state, map, state_version};
  }
  std::shared_ptr<const FoxgloveSnapshot> latest_foxglove() {
    const std::lock_guard lock(mu);
    return foxglove;
  }

  bool authorised(const boost::beast::http::request<boost::beast::http::string_body>& req) const;
  /// Parses and queues one command; returns the JSON reply.
  std::string enqueue(std::string_view text);
};

// One connection's place under the connection cap, given back when the session ends.
class ConnectionSlot {
 public:
  explicit ConnectionSlot(WebServer::Impl* s) : s_(s) { ++s_->connections; }
  ConnectionSlot(ConnectionSlot&& o) noexcept : s_(std::exchange(o.s_, nullptr)) {}
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;
  ~ConnectionSlot() {
    if (s_) --s_->connections;
  }

 private:
  WebServer::Impl* s_;
};

}  // namespace cairn::base
