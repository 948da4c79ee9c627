// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What the console's test clients (server_test, adit_console_feed) share: Beast's names and a
// synchronous WebSocket connection to a running server.
#include <string>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

namespace adit::console::testing {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Json = nlohmann::json;

/// Connects to ws://host:port{path} with `token` as `Authorization: Bearer` (none when empty)
/// and, when given, an `Origin` header (as a browser would send).
inline websocket::stream<tcp::socket> openWebSocket(net::io_context& ioc, const std::string& host,
                                                    const std::string& port, const std::string& path,
                                                    const std::string& token = "", const std::string& origin = "") {
  tcp::resolver resolver(ioc);
  websocket::stream<tcp::socket> ws(ioc);
  net::connect(ws.next_layer(), resolver.resolve(host, port));
  ws.set_option(websocket::stream_base::decorator([token, origin](websocket::request_type& req) {
    if (!token.empty()) req.set(http::field::authorization, "Bearer " + token);
    if (!origin.empty()) req.set(http::field::origin, origin);
  }));
  ws.handshake(host + ":" + port, path);
  ws.read_message_max(64 << 20);
  return ws;
}

/// The next message as JSON (throws on a closed stream, which fails the caller).
inline Json readJson(websocket::stream<tcp::socket>& ws) {
  beast::flat_buffer b;
  ws.read(b);
  return Json::parse(beast::buffers_to_string(b.data()));
}

}  // namespace adit::console::testing
