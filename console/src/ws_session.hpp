// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The console's WebSocket transport: one session per robot or viewer connection (transport.cpp
// holds the HTTP side and the acceptor). Internal: not installed.

#include "server_impl.hpp"

namespace adit::console {

// One WebSocket connection, robot or viewer: a read loop and a write queue (one write in flight,
// as Beast requires). A viewer's queue is bounded by dropping the oldest telemetry.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  // `credential_robot`: the robot id this connection's credential may speak for; empty for the
  // operator token (any robot).
  WsSession(tcp::socket&& socket, Server::Impl& impl, bool robot, std::string credential_robot)
      : ws_(std::move(socket)), impl_(impl), robot_(robot), credential_robot_(std::move(credential_robot)) {}

  void run(Request req) {
    // A viewer never sends: without pings its idle connection would time out after 5 minutes.
    auto timeouts = websocket::stream_base::timeout::suggested(beast::role_type::server);
    timeouts.keep_alive_pings = true;
    ws_.set_option(timeouts);
    ws_.read_message_max(kMaxMessageBytes);
    ws_.text(true);
    ws_.async_accept(req, beast::bind_front_handler(&WsSession::onAccept, shared_from_this()));
  }

  void send(const Json& j, bool telemetry = false) { send(std::make_shared<const std::string>(j.dump()), telemetry); }

  void send(std::shared_ptr<const std::string> text, bool telemetry) {
    if (closing_) return;
    const std::size_t limit = robot_ ? kMaxRobotQueue : kMaxViewerQueue;
    if (queue_.size() >= limit && robot_) {  // it stopped reading: drop it; it resends after reconnecting
      closeAfterWrites(websocket::close_code::policy_error);
      return;
    }
    // A viewer that does not keep up loses its oldest telemetry first (counted, reported as
    // `lag`); when what it has queued is still over the count or the bytes (the snapshot and the
    // other messages are never dropped), it is too slow to serve: closed, and logged.
    const std::size_t first = writing_ ? 1 : 0;  // the front one is being written
    while (!robot_ && (queue_.size() >= limit || queued_bytes_ + text->size() > impl_.options.viewer_queue_bytes)) {
      auto victim = std::find_if(queue_.begin() + static_cast<long>(first), queue_.end(),
                                 [](const Out& o) { return o.telemetry; });
      if (victim == queue_.end()) {
        logLine("closed a viewer too slow to read: " + std::to_string(queued_bytes_) + " bytes in " +
                std::to_string(queue_.size()) + " messages queued");
        closeAfterWrites(websocket::close_code::try_again_later);
        return;
      }
      queued_bytes_ -= victim->text->size();
      queue_.erase(victim);
      ++dropped_;
    }
    queued_bytes_ += text->size();
    queue_.push_back({std::move(text), telemetry});
    if (!writing_) writeNext();
  }

  void closeAfterWrites(websocket::close_code code) {
    closing_ = true;
    close_code_ = code;
    if (!writing_) writeNext();
  }

  bool robot() const { return robot_; }
  const std::string& credentialRobot() const { return credential_robot_; }
  const std::string& robotId() const { return robot_id_; }
  double radius() const { return radius_; }
  void bind(const std::string& id, double radius) {
    robot_id_ = id;
    radius_ = radius;
  }
  TokenBucket& ownBucket() { return own_bucket_; }
  // Answers a refused message with an error; the connection's first refusal is logged too (an
  // honest robot whose messages are refused is a bug to find; a flood of bad ones logs one line).
  void refuse(const std::string& reason, std::optional<std::int64_t> seq) {
    if (!refusal_logged_) {
      refusal_logged_ = true;
      logLine("refused a message of " + (robot_id_.empty() ? std::string("a robot connection") : "robot " + robot_id_) +
              (seq ? " (seq " + std::to_string(*seq) + ")" : std::string()) + ": " + reason +
              " (later refusals on this connection are not logged)");
    }
    send(errorJson(reason, seq));
  }
  // A robot's clock on this connection (protocol.md "Limits"): each message newer than the
  // newest seen (a higher seq) must not go back in time. A reconnection may start a new run
  // whose clock starts again, so the check is per connection.
  // (A microsecond of tolerance: t_k + dt and (k + 1) dt differ in the last bit.)
  static constexpr double kClockTolerance = 1e-6;
  Status checkTime(std::int64_t seq, double t) {
    if (seq <= newest_seq_) return Status::okStatus();  // a resend or a reordering: checked when new
    if (t < newest_t_ - kClockTolerance)
      return invalidArgument("t " + std::to_string(t) + " of seq " + std::to_string(seq) + " is before t " +
                             std::to_string(newest_t_) + " of seq " + std::to_string(newest_seq_) +
                             " (a robot's time never goes back on one connection)");
    newest_seq_ = seq;
    newest_t_ = t;
    return Status::okStatus();
  }

 private:
  struct Out {
    std::shared_ptr<const std::string> text;
    bool telemetry = false;
  };

  void onAccept(beast::error_code ec) {
    if (ec) return;
    if (!robot_) impl_.onViewerOpen(shared_from_this());
    read();
  }

  void read() {
    ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::onRead, shared_from_this()));
  }

  void onRead(beast::error_code ec, std::size_t) {
    if (ec) {  // closed, or oversized (Beast has closed it with 1009 then)
      if (ec == websocket::error::message_too_big) logLine("closed a connection that sent an oversized message");
      dead_ = true;
      if (robot_) impl_.onRobotClosed(*this);
      return;
    }
    std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    if (robot_) {
      impl_.onRobotText(*this, text);
      // The robot's rate: the next read waits until its bucket allows it. Not reading is what
      // slows the sender (TCP's window fills), so a flood costs the server a timer, not memory.
      const double wait = impl_.throttle(*this, text.size());
      if (wait > 0.0 && !dead_) {
        if (!throttle_logged_) {
          throttle_logged_ = true;
          logLine("robot " + (robot_id_.empty() ? std::string("(before hello)") : robot_id_) +
                  " is over its rate; its messages are read more slowly");
        }
        timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(wait)));
        timer_.async_wait([self = shared_from_this()](beast::error_code waited) {
          if (!waited && !self->dead_) self->read();
        });
        return;
      }
    } else {
      send(errorJson("viewers send nothing; commands go to POST /api/commands"));
    }
    if (!dead_) read();
  }

  void writeNext() {
    if (dead_) return;
    if (dropped_ > 0) {
      auto lag = std::make_shared<const std::string>(Json{{"type", "lag"}, {"dropped", dropped_}}.dump());
      queued_bytes_ += lag->size();
      queue_.push_front({std::move(lag), false});
      dropped_ = 0;
    }
    if (queue_.empty()) {
      if (closing_ && !close_sent_) {
        close_sent_ = true;
        ws_.async_close(close_code_, [self = shared_from_this()](beast::error_code) { self->dead_ = true; });
      }
      return;
    }
    writing_ = true;
    ws_.async_write(net::buffer(*queue_.front().text),
                    beast::bind_front_handler(&WsSession::onWrite, shared_from_this()));
  }

  void onWrite(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (ec) {
      dead_ = true;
      return;
    }
    queued_bytes_ -= queue_.front().text->size();
    queue_.pop_front();
    writeNext();
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  Server::Impl& impl_;
  const bool robot_;
  const std::string credential_robot_;
  std::deque<Out> queue_;
  bool writing_ = false, closing_ = false, close_sent_ = false, dead_ = false;
  websocket::close_code close_code_ = websocket::close_code::normal;
  std::size_t dropped_ = 0;
  std::size_t queued_bytes_ = 0;  // of the texts in queue_ (a broadcast text shared by viewers counts for each)
  std::string robot_id_;
  double radius_ = 0.0;
  net::steady_timer timer_{ws_.get_executor()};  // a throttled read's wait
  bool throttle_logged_ = false, refusal_logged_ = false;
  TokenBucket own_bucket_;  // before hello: the connection's own rate
  std::int64_t newest_seq_ = 0;
  double newest_t_ = -std::numeric_limits<double>::infinity();

 public:
  bool dead() const { return dead_; }
};

}  // namespace adit::console
