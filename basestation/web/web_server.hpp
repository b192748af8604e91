// The web view's HTTP + WebSocket server (Boost.Beast, one port for both), on its own
// thread. The base's main loop never waits on it: it swaps in immutable snapshots
// (publish_*: a pointer swap under a mutex) and drains the commands browsers sent
// (take_commands: a bounded queue). Every request and the socket upgrade need the token
// (query `token=`, header `X-Cairn-Token` or `Authorization: Bearer`); without it: 401.
// Sizes are capped (headers, bodies, messages, connections); hostile input closes that
// connection or gets an error reply, counted, never more. The same port speaks the
// Foxglove WebSocket protocol to a client that offers its subprotocol (foxglove_session.hpp).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "basestation/web/foxglove_snapshot.hpp"
#include "basestation/web/web_command.hpp"
#include "basestation/web/web_map_tiles.hpp"

namespace cairn::base {

struct WebServerOptions {
  std::string listen = "127.0.0.1";
  std::uint16_t port = 0;  // 0: any free port (see WebServer::port)
  std::string token;
  // The page: app_js goes inline where index_html loads "app.js" (one request, one token check).
  std::string_view index_html, app_js;
  // A Foxglove client whose one write has not finished for this long is closed (it does not read).
  std::chrono::milliseconds foxglove_stall_limit{10'000};
};

struct WebCounters {
  std::atomic<std::uint64_t> requests{0}, unauthorized{0}, bad_requests{0}, commands_queued{0}, commands_refused{0},
      queue_full{0}, connections_refused{0}, messages_sent{0};
  // Foxglove clients: sessions accepted, ops refused (status error sent), messageData frames
  // sent, ticks that found a newer message while the socket was still busy (it waits and a
  // newer one replaces it), connections closed for a stalled write.
  std::atomic<std::uint64_t> foxglove_sessions{0}, foxglove_ops_refused{0}, foxglove_messages_sent{0},
      foxglove_skipped{0}, foxglove_dropped{0};
};

/// A command from a browser, numbered in the order received.
struct QueuedWebCommand {
  std::uint64_t id = 0;
  WebCommand command;
};

class WebServer {
 public:
  /// Binds and starts the thread; throws std::runtime_error naming the address if it cannot bind.
  explicit WebServer(WebServerOptions options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  std::uint16_t port() const { return port_; }
  /// The live state (JSON text, pushed to every socket and served at /api/state).
  void publish_state(std::shared_ptr<const std::string> json);
  /// The map (JSON text with the PNG inside), pushed when it changes and on connect.
  void publish_map(std::shared_ptr<const WebMapSnapshot> map);
  /// The Foxglove channels and their latest messages (foxglove_channels.hpp builds them).
  void publish_foxglove(std::shared_ptr<const FoxgloveSnapshot> snapshot);
  /// The commands received since the last call, oldest first.
  std::vector<QueuedWebCommand> take_commands();
  const WebCounters& counters() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

}  // namespace cairn::base
