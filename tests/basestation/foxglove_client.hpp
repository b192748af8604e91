// A Foxglove WebSocket protocol client for the tests (Boost.Beast, loopback): offers the
// subprotocol, reads with a time limit (a missing message fails, never hangs), and knows
// the messageData frame and base64.
#pragma once

#include <utility>  // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace cairn::base::test {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

struct WsMessage {
  bool binary = false;
  std::string data;
};

struct MessageData {
  std::uint32_t subscription = 0;
  std::uint64_t stamp_ns = 0;
  std::string payload;
};

/// Reads a binary messageData frame; nullopt if it is anything else.
inline std::optional<MessageData> message_data(const WsMessage& m) {
  if (!m.binary || m.data.size() < 13 || static_cast<std::uint8_t>(m.data[0]) != 0x01) return std::nullopt;
  MessageData d;
  for (int i = 0; i < 4; ++i) d.subscription |= std::uint32_t{static_cast<std::uint8_t>(m.data[1 + i])} << (8 * i);
  for (int i = 0; i < 8; ++i) d.stamp_ns |= std::uint64_t{static_cast<std::uint8_t>(m.data[5 + i])} << (8 * i);
  d.payload = m.data.substr(13);
  return d;
}

inline std::vector<std::uint8_t> unbase64(const std::string& s) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
  };
  std::vector<std::uint8_t> out;
  std::uint32_t acc = 0;
  int bits = 0;
  for (const char c : s) {
    const int v = value(c);
    if (v < 0) continue;  // '=' padding
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<std::uint8_t>((acc >> bits) & 0xff));
    }
  }
  return out;
}

class FoxgloveClient {
 public:
  /// Connects and upgrades, offering `subprotocol` (empty: none). `error` is the handshake's outcome.
  FoxgloveClient(std::uint16_t port, const std::string& target, const std::string& subprotocol = "foxglove.websocket.v1") {
    beast::get_lowest_layer(ws_).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    ws_.set_option(websocket::stream_base::decorator([subprotocol](websocket::request_type& req) {
      if (!subprotocol.empty()) req.set(http::field::sec_websocket_protocol, subprotocol);
    }));
    websocket::response_type res;
    ws_.handshake(res, "127.0.0.1", target, error);
    accepted_subprotocol = std::string(res[http::field::sec_websocket_protocol]);
  }

  /// The next message, or nullopt if none came within `limit` (or the connection failed).
  std::optional<WsMessage> read(std::chrono::milliseconds limit = std::chrono::seconds(5)) {
    bool done = false;
    beast::error_code ec;
    ws_.async_read(buffer_, [&](beast::error_code e, std::size_t) {
      done = true;
      ec = e;
    });
    ioc_.restart();
    ioc_.run_for(limit);
    if (!done) {  // give up: cancel and let the handler run
      beast::get_lowest_layer(ws_).cancel();
      ioc_.restart();
      ioc_.run();
      return std::nullopt;
    }
    if (ec) return std::nullopt;
    WsMessage m{!ws_.got_text(), beast::buffers_to_string(buffer_.data())};
    buffer_.consume(buffer_.size());
    return m;
  }

  /// Reads until a text message with this op (skipping others, up to `max_skipped`).
  std::optional<nlohmann::json> next_op(const std::string& op, std::vector<WsMessage>* skipped = nullptr, int max_skipped = 1000) {
    for (int i = 0; i <= max_skipped; ++i) {
      const std::optional<WsMessage> m = read();
      if (!m) return std::nullopt;
      if (!m->binary) {
        nlohmann::json j = nlohmann::json::parse(m->data, nullptr, false);
        if (j.is_object() && j.value("op", "") == op) return j;
      }
      if (skipped) skipped->push_back(*m);
    }
    return std::nullopt;
  }

  /// Reads until a messageData frame (skipping text messages).
  std::optional<MessageData> next_message_data(int max_skipped = 1000) {
    for (int i = 0; i <= max_skipped; ++i) {
      const std::optional<WsMessage> m = read();
      if (!m) return std::nullopt;
      if (auto d = message_data(*m)) return d;
    }
    return std::nullopt;
  }

  void send_text(const std::string& text) {
    ws_.text(true);
    ws_.write(asio::buffer(text));
  }
  void send_binary(const std::string& bytes) {
    ws_.binary(true);
    ws_.write(asio::buffer(bytes));
  }

  beast::error_code error;
  std::string accepted_subprotocol;

 private:
  asio::io_context ioc_;
  websocket::stream<beast::tcp_stream> ws_{ioc_};
  beast::flat_buffer buffer_;
};

}  // namespace cairn::base::test
