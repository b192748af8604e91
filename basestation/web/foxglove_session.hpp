// One Foxglove client on the web server's port (Foxglove WebSocket protocol, subprotocol
// foxglove.websocket.v1; docs/web-view.md "Foxglove"): serverInfo and advertise on
// connect, advertise/unadvertise as the snapshot's channels change, subscribe and
// unsubscribe (parse_foxglove_op; anything else a status error, counted), and binary
// messageData frames of the newest message on each subscribed channel. Bounded like the
// page's socket: a busy connection skips messages instead of queueing them, and one whose
// write stalls past the limit is closed.
#pragma once

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/http.hpp>
#include <cstddef>
#include <string_view>

#include "basestation/web/web_server_impl.hpp"

namespace cairn::base {

inline constexpr std::string_view kFoxgloveSubprotocol = "foxglove.websocket.v1";
inline constexpr std::size_t kMaxFoxgloveSubscriptions = 128;  // per connection

/// True if the upgrade request lists foxglove.websocket.v1 in Sec-WebSocket-Protocol.
bool offers_foxglove_subprotocol(const boost::beast::http::request<boost::beast::http::string_body>& req);

/// Accepts the upgrade with the subprotocol and runs the session on the server's thread.
void start_foxglove_session(boost::asio::ip::tcp::socket&& socket, WebServer::Impl* server, ConnectionSlot slot,
                            const boost::beast::http::request<boost::beast::http::string_body>& req);

}  // namespace cairn::base
