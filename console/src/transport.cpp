// SPDX-License-Identifier: BSD-3-Clause
// The console's transport: the acceptor and each HTTP connection until it upgrades to a
// WebSocket (ws_session.hpp), with the upgrade's refusals decided by routes.cpp.
#include "ws_session.hpp"

namespace adit::console {

// One HTTP connection: requests in turn (keep-alive) until it upgrades to a WebSocket.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server::Impl& impl) : stream_(std::move(socket)), impl_(impl) {}
  void run() { read(); }

 private:
  void read() {
    parser_.emplace();
    parser_->body_limit(kMaxMessageBytes);
    parser_->header_limit(16 * 1024);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::onRead, shared_from_this()));
  }

  void onRead(beast::error_code ec, std::size_t) {
    if (ec == http::error::body_limit) {
      Response res{http::status::payload_too_large, 11};
      res.set(http::field::content_type, "application/json");
      res.body() = Json{{"error", "the body is larger than " + std::to_string(kMaxMessageBytes) + " bytes"}}.dump();
      res.keep_alive(false);
      res.prepare_payload();
      write(std::move(res));
      return;
    }
    if (ec) return;  // closed, timed out or not HTTP
    Request req = parser_->release();
    if (websocket::is_upgrade(req)) {
      const std::string target(req.target());
      const std::string path = target.substr(0, target.find('?'));
      const bool robot = path == "/ws/robot", viewer = path == "/ws/view";
      if (robot || viewer) {
        // Who may open it is decided before the handshake is accepted: a refusal is a plain
        // HTTP answer (403 foreign origin, 401 no or wrong credential) and no WebSocket exists.
        std::string credential_robot;
        if (std::optional<Response> refused = impl_.authorizeUpgrade(req, robot, &credential_robot)) {
          refused->keep_alive(false);
          write(std::move(*refused));
          return;
        }
        stream_.expires_never();
        std::make_shared<WsSession>(stream_.release_socket(), impl_, robot, std::move(credential_robot))
            ->run(std::move(req));
        return;
      }
    }
    Response res = impl_.handle(req);
    if (req.method() == http::verb::head) {  // the GET's headers, no body
      const std::size_t length = res.body().size();
      res.body().clear();
      res.content_length(length);
    }
    write(std::move(res));
  }

  void write(Response res) {
    auto sp = std::make_shared<Response>(std::move(res));
    http::async_write(stream_, *sp, [self = shared_from_this(), sp](beast::error_code ec, std::size_t) {
      if (ec) return;
      if (!sp->keep_alive()) {
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
  Server::Impl& impl_;
};

void Server::Impl::accept() {
  acceptor.async_accept(ioc, [this](beast::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec != net::error::operation_aborted) logLine("accept: " + ec.message());
      if (!acceptor.is_open()) return;
    } else {
      std::make_shared<HttpSession>(std::move(socket), *this)->run();
    }
    accept();
  });
}

}  // namespace adit::console
