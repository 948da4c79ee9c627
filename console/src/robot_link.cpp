// SPDX-License-Identifier: BSD-3-Clause
#include "adit/console/robot_link.hpp"

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "adit/console/protocol_limits.hpp"
#include "adit/map/file_io.hpp"
#include "protocol.hpp"

namespace adit::console {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::ordered_json;

namespace {

struct Url {
  std::string host, port, path;
};

StatusOr<Url> parseUrl(const std::string& url) {
  const std::string scheme = "ws://";
  if (url.compare(0, scheme.size(), scheme) != 0)
    return invalidArgument("live URL '" + url + "': must start with ws:// (e.g. ws://127.0.0.1:8080)");
  std::string rest = url.substr(scheme.size());
  Url u;
  const std::size_t slash = rest.find('/');
  u.path = slash == std::string::npos || slash + 1 == rest.size() ? "/ws/robot" : rest.substr(slash);
  rest = rest.substr(0, slash);
  const std::size_t colon = rest.rfind(':');
  u.host = colon == std::string::npos ? rest : rest.substr(0, colon);
  u.port = colon == std::string::npos ? "80" : rest.substr(colon + 1);
  if (u.host.empty()) return invalidArgument("live URL '" + url + "': no host");
  if (u.port.empty() || u.port.size() > 5 || !std::all_of(u.port.begin(), u.port.end(), ::isdigit) ||
      std::stoi(u.port) < 1 || std::stoi(u.port) > 65535)
    return invalidArgument("live URL '" + url + "': port '" + u.port + "' is not 1-65535");
  return u;
}

}  // namespace

Status RobotHello::validate() const {
  if (!protocol::validRobotId(robot)) return invalidArgument("robot id '" + robot + "': must be 1-64 characters of [A-Za-z0-9_.-]");
  if (map.empty()) return invalidArgument("hello: map name is empty");
  if (map_hash.empty()) return invalidArgument("hello: map hash is empty");
  if (!std::isfinite(radius_m) || radius_m <= 0.0) return invalidArgument("hello: radius must be finite and > 0");
  return {};
}

StatusOr<ReceivedCommand> parseCommand(const std::string& text) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return invalidArgument("command: not a JSON object");
  if (!j.contains("type") || j["type"] != "command") return invalidArgument("command: type is not \"command\"");
  ReceivedCommand c;
  // An id in the protocol's range, read as what it is: 2^64 - 1 must not become -1.
  if (!j.contains("command_id") || !j["command_id"].is_number_unsigned() || j["command_id"].get<std::uint64_t>() < 1 ||
      j["command_id"].get<std::uint64_t>() > static_cast<std::uint64_t>(kMaxSeq))
    return invalidArgument("command: command_id must be an integer in 1..9007199254740991 (2^53 - 1)");
  c.id = j["command_id"].get<std::int64_t>();
  if (j.contains("operator") && j["operator"].is_string()) c.operator_name = j["operator"].get<std::string>();
  // The same parser as the centre's for the operator's request; then this robot's own limits
  // (the centre is trusted no more than any other input: a velocity of 1e308 is not a command a
  // robot executes).
  const std::string kind = j.contains("kind") && j["kind"].is_string() ? j["kind"].get<std::string>() : "?";
  const std::string where = "command " + std::to_string(c.id) + " (" + kind + "): ";
  StatusOr<protocol::CommandArgs> args = protocol::parseCommandArgs(j);
  if (!args.ok()) return invalidArgument(where + args.status().message());
  c.kind = args->kind;
  c.goal = args->goal;
  c.velocity = args->velocity;
  c.roadway = args->roadway;
  if (c.goal && !(c.goal->cwiseAbs().maxCoeff() <= kMaxCoordinate))
    return invalidArgument(where + "goal must be [x, y, z] of finite numbers within +-1e7 m");
  if (c.velocity && !(c.velocity->norm() <= kMaxManualSpeed))
    return invalidArgument(where + "velocity must be [vx, vy, vz] of finite numbers, at most 2 m/s");
  if ((c.kind == "block" || c.kind == "reopen") && c.roadway.empty())
    return invalidArgument(where + "roadway must be a non-empty string");
  return c;
}

struct RobotLink::Impl {
  using Stream = websocket::stream<beast::tcp_stream>;
  struct Outgoing {
    std::uint64_t seq;
    std::string text;
    bool droppable;  // telemetry
  };

  Impl(Url u, RobotHello h, LinkOptions o) : url(std::move(u)), hello(std::move(h)), options(o) {}

  Url url;
  RobotHello hello;
  LinkOptions options;
  net::io_context ioc;
  net::executor_work_guard<net::io_context::executor_type> work{ioc.get_executor()};
  std::thread thread;

  // I/O thread only. Each connection has a generation; handlers of an older one do nothing.
  // Each connection also has its own read buffer: a read of the old connection that completed
  // with a whole frame (an ack just before the peer's reset) but found its generation gone would
  // otherwise leave that frame in front of the next connection's welcome, which then fails to
  // parse and costs a spurious reconnect (a hello the centre counts, a connection the link does
  // not).
  std::shared_ptr<Stream> ws;
  std::shared_ptr<beast::flat_buffer> rbuf;
  tcp::resolver resolver{ioc};
  net::steady_timer retry{ioc};
  std::uint64_t generation = 0;
  bool online = false, writing = false;
  std::uint64_t written_upto = 0;      // highest seq written on this connection (or acked at welcome)
  std::uint64_t max_written_ever = 0;  // resends are writes at or below it
  double backoff_s = 0.1;

  // Shared with the caller's thread.
  mutable std::mutex mu;
  std::condition_variable cv;
  std::deque<Outgoing> outbox;  // ascending seq
  std::uint64_t next_seq = 1;
  std::deque<ReceivedCommand> inbox;
  std::set<std::int64_t> received;               // command ids seen (answered or not)
  std::map<std::int64_t, std::string> answers;   // command id -> its last command_result (no robot/seq)
  LinkStats stats;
  bool first_done = false;
  Status first_status;
  bool stopping = false;

  std::string helloText() const {
    json j;
    j["type"] = "hello";
    j["robot"] = hello.robot;
    j["map"] = hello.map;
    j["map_hash"] = hello.map_hash;
    j["radius"] = hello.radius_m;
    return j.dump();
  }

  // Gives `j` the robot and the next seq and queues it; caller holds `mu`.
  std::uint64_t enqueueLocked(json j, bool droppable) {
    const std::uint64_t seq = next_seq++;
    j["robot"] = hello.robot;
    j["seq"] = seq;
    outbox.push_back({seq, j.dump(), droppable});
    stats.last_seq = seq;
    return seq;
  }

  void startConnect() {
    const std::uint64_t g = ++generation;
    ws = std::make_shared<Stream>(ioc);
    rbuf = std::make_shared<beast::flat_buffer>();
    resolver.async_resolve(url.host, url.port, [this, g](beast::error_code ec, tcp::resolver::results_type results) {
      if (g != generation) return;
      if (ec) return fail(g, "resolving " + url.host + ": " + ec.message(), false);
      auto s = ws;
      beast::get_lowest_layer(*s).expires_after(std::chrono::seconds(5));
      beast::get_lowest_layer(*s).async_connect(results, [this, g, s](beast::error_code ec2, const tcp::endpoint&) {
        if (g != generation) return;
        if (ec2) return fail(g, "connecting to " + url.host + ":" + url.port + ": " + ec2.message(), false);
        beast::get_lowest_layer(*s).expires_never();
        s->set_option(websocket::stream_base::timeout::suggested(beast::role_type::client));
        // The robot's credential (console/doc/protocol.md, "Who may connect"), as a header: it
        // never appears in a URL.
        s->set_option(websocket::stream_base::decorator([token = options.token](websocket::request_type& req) {
          if (!token.empty()) req.set(beast::http::field::authorization, "Bearer " + token);
        }));
        auto res = std::make_shared<websocket::response_type>();
        s->async_handshake(*res, url.host + ":" + url.port, url.path, [this, g, s, res](beast::error_code ec3) {
          if (g != generation) return;
          // 401 or 403: the centre refused this robot's credential or origin; retrying with the
          // same credential cannot help, so the first connect() says it at once.
          const unsigned code = res->result_int();
          if (ec3 && (code == 401 || code == 403)) {
            const json body = json::parse(res->body(), nullptr, false);
            const std::string why = body.is_object() && body.contains("error") && body["error"].is_string()
                                        ? body["error"].get<std::string>().substr(0, 300)
                                        : std::string(res->reason());
            return fail(g, "the centre refused the connection (" + std::to_string(code) + "): " + why, true);
          }
          if (ec3) return fail(g, "WebSocket handshake on " + url.path + ": " + ec3.message(), false);
          auto text = std::make_shared<std::string>(helloText());
          s->text(true);
          s->async_write(net::buffer(*text), [this, g, s, text](beast::error_code ec4, std::size_t) {
            if (g != generation) return;
            if (ec4) return fail(g, "sending hello: " + ec4.message(), false);
            auto b = rbuf;
            s->async_read(*b, [this, g, s, b](beast::error_code ec5, std::size_t) { onWelcome(g, ec5, *b); });
          });
        });
      });
    });
  }

  void onWelcome(std::uint64_t g, beast::error_code ec, beast::flat_buffer& buf) {
    if (g != generation) return;
    if (ec) return fail(g, "waiting for welcome: " + ec.message(), false);
    const json j = json::parse(beast::buffers_to_string(buf.data()), nullptr, false);
    buf.consume(buf.size());
    if (j.is_object() && j.value("type", "") == "error")
      return fail(g, "the centre refused the robot: " + j.value("reason", std::string("(no reason)")), true);
    if (!j.is_object() || j.value("type", "") != "welcome" || !j.contains("acked_seq") ||
        !j["acked_seq"].is_number_unsigned())
      return fail(g, "expected welcome with acked_seq, got: " + j.dump().substr(0, 200), true);
    const std::uint64_t acked = j["acked_seq"].get<std::uint64_t>();
    if (acked >= std::uint64_t(kMaxSeq))
      return fail(g, "welcome.acked_seq " + std::to_string(acked) + " leaves no seq to send (the protocol's seqs end at " +
                         std::to_string(kMaxSeq) + "): give the robot another id", true);
    {
      // After the first welcome the centre can only hold what this link sent: a larger acked_seq
      // is the centre's error (or a forgery), and taking it would drop unsent messages as stored.
      std::unique_lock lock(mu);
      if (stats.connections > 0 && acked >= next_seq) {
        const std::string why = "welcome.acked_seq " + std::to_string(acked) + " is beyond the last seq sent (" +
                                std::to_string(next_seq - 1) + ")";
        lock.unlock();
        return fail(g, why, true);
      }
      // A robot id the centre knows from an earlier run: this run's seq goes on after what the
      // centre holds (else its first messages would count as stored already). Nothing is queued
      // before the first welcome: connect() returns after it.
      if (stats.connections == 0 && acked >= next_seq) next_seq = acked + 1;
      while (!outbox.empty() && outbox.front().seq <= acked) outbox.pop_front();
      stats.acked_seq = std::max(stats.acked_seq, acked);
      ++stats.connections;
      stats.connected = true;
      stats.outbox = outbox.size();
      first_done = true;
    }
    cv.notify_all();
    online = true;
    writing = false;
    written_upto = acked;
    backoff_s = 0.1;
    startRead(g);
    pump(g);
  }

  void startRead(std::uint64_t g) {
    auto s = ws;
    auto b = rbuf;
    s->async_read(*b, [this, g, s, b](beast::error_code ec, std::size_t) {
      if (g != generation) return;
      if (ec) return fail(g, "connection lost: " + ec.message(), false);
      const std::string text = beast::buffers_to_string(b->data());
      b->consume(b->size());
      onMessage(text);
      startRead(g);
      pump(g);
    });
  }

  void onMessage(const std::string& text) {
    const json j = json::parse(text, nullptr, false);
    const std::string type = j.is_object() ? j.value("type", "") : "";
    std::lock_guard lock(mu);
    if (type == "ack" && j.contains("seq") && j["seq"].is_number_unsigned()) {
      const std::uint64_t seq = j["seq"].get<std::uint64_t>();
      if (seq >= next_seq) {  // never sent: not an acknowledgement of anything
        stats.last_error = "ack for seq " + std::to_string(seq) + ", beyond the last seq sent (" +
                           std::to_string(next_seq - 1) + "); ignored";
        return;
      }
      auto it = std::lower_bound(outbox.begin(), outbox.end(), seq,
                                 [](const Outgoing& o, std::uint64_t s) { return o.seq < s; });
      if (it != outbox.end() && it->seq == seq) outbox.erase(it);
      stats.acked_seq = std::max(stats.acked_seq, seq);
      stats.outbox = outbox.size();
      cv.notify_all();
    } else if (type == "command") {
      StatusOr<ReceivedCommand> c = parseCommand(text);
      if (!c.ok()) {
        stats.last_error = c.status().message();
        // Refused here, so the centre does not resend it forever (an id is needed to answer).
        if (j.contains("command_id") && j["command_id"].is_number_integer()) {
          const std::int64_t id = j["command_id"].get<std::int64_t>();
          CommandResult r;
          r.command_id = id;
          r.result = "refused";
          r.reason = c.status().message().substr(0, 512);  // within the centre's size limit
          if (received.insert(id).second) answers[id] = toJson(r);
          enqueueLocked(json::parse(answers[id]), false);
        }
        return;
      }
      if (auto a = answers.find(c->id); a != answers.end()) {
        ++stats.duplicate_commands;
        enqueueLocked(json::parse(a->second), false);  // the stored answer again, no execution
      } else if (!received.insert(c->id).second) {
        ++stats.duplicate_commands;  // queued already, its answer is coming
      } else {
        inbox.push_back(std::move(*c));
      }
    } else if (type == "error") {
      stats.last_error = "the centre: " + j.value("reason", std::string("(no reason)"));
    }
  }

  // Writes the next unwritten message of this connection, one at a time.
  void pump(std::uint64_t g) {
    if (g != generation || !online || writing) return;
    std::shared_ptr<std::string> text;
    std::uint64_t seq = 0;
    {
      std::lock_guard lock(mu);
      auto it = std::upper_bound(outbox.begin(), outbox.end(), written_upto,
                                 [](std::uint64_t s, const Outgoing& o) { return s < o.seq; });
      if (it == outbox.end()) return;
      text = std::make_shared<std::string>(it->text);
      seq = it->seq;
    }
    writing = true;
    auto s = ws;
    s->async_write(net::buffer(*text), [this, g, s, text, seq](beast::error_code ec, std::size_t) {
      if (g != generation) return;
      writing = false;
      if (ec) return fail(g, "sending: " + ec.message(), false);
      written_upto = seq;
      {
        std::lock_guard lock(mu);
        ++stats.sent;
        if (seq <= max_written_ever) ++stats.resent;
      }
      max_written_ever = std::max(max_written_ever, seq);
      pump(g);
    });
  }

  // Drops the connection and tries again after the backoff. `refused`: the centre said no; the
  // first connection then fails at once instead of retrying until the timeout.
  void fail(std::uint64_t g, const std::string& why, bool refused) {
    if (g != generation) return;
    ++generation;
    online = false;
    writing = false;
    if (ws) {
      beast::error_code ignored;
      beast::get_lowest_layer(*ws).socket().close(ignored);
    }
    {
      std::lock_guard lock(mu);
      stats.last_error = why;
      stats.connected = false;
      if (!first_done && refused) {
        first_done = true;
        first_status = failedPrecondition(why);
      }
      if (stopping || (first_done && !first_status.ok())) {
        cv.notify_all();
        return;
      }
    }
    cv.notify_all();
    retry.expires_after(std::chrono::milliseconds(int(backoff_s * 1000)));
    backoff_s = std::min(2.0 * backoff_s, options.max_backoff_s);
    retry.async_wait([this](beast::error_code ec) {
      if (!ec) startConnect();
    });
  }
};

RobotLink::RobotLink(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

RobotLink::~RobotLink() {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.mu);
    m.stopping = true;
  }
  m.cv.notify_all();
  m.ioc.stop();
  if (m.thread.joinable()) m.thread.join();
}

StatusOr<std::unique_ptr<RobotLink>> RobotLink::connect(const std::string& url, const RobotHello& hello,
                                                        const LinkOptions& options) {
  ADIT_ASSIGN_OR_RETURN(Url u, parseUrl(url));
  ADIT_RETURN_IF_ERROR(hello.validate());
  if (options.outbox_limit < 1 || !(options.connect_timeout_s > 0.0) || !(options.max_backoff_s > 0.0))
    return invalidArgument("link options: outbox_limit >= 1, timeouts > 0");
  auto impl = std::make_unique<Impl>(u, hello, options);
  Impl& m = *impl;
  std::unique_ptr<RobotLink> link(new RobotLink(std::move(impl)));
  m.thread = std::thread([&m] { m.ioc.run(); });
  net::post(m.ioc, [&m] { m.startConnect(); });
  std::unique_lock lock(m.mu);
  const bool done = m.cv.wait_for(lock, std::chrono::duration<double>(options.connect_timeout_s), [&] { return m.first_done; });
  if (!done) {
    char within[32];
    std::snprintf(within, sizeof within, "%.1f s", options.connect_timeout_s);
    return failedPrecondition("no console at " + url + " (" + m.stats.last_error + ") within " + within);
  }
  if (!m.first_status.ok()) return m.first_status;
  lock.unlock();
  return link;
}

StatusOr<std::uint64_t> RobotLink::send(const std::string& json_object) {
  // The centre's own parser: what it would refuse is refused here, before it takes a seq and
  // a place in the outbox, with the words the centre would use.
  StatusOr<protocol::Json> parsed = protocol::parseObject(json_object);
  if (!parsed.ok()) return invalidArgument("link: " + parsed.status().message());
  StatusOr<protocol::Body> body = protocol::parseBody(*parsed);
  if (!body.ok()) return invalidArgument("link: " + body.status().message());
  json j = json::parse(json_object);  // in the robot's field order, for the outbox
  if (Status size = protocol::checkSize(protocol::typeOf(*body), json_object.size()); !size.ok())
    return invalidArgument("link: " + size.message());
  const bool droppable = std::holds_alternative<Telemetry>(*body);
  Impl& m = *impl_;
  std::unique_lock lock(m.mu);
  while (m.outbox.size() >= m.options.outbox_limit && !m.stopping) {
    auto oldest = std::find_if(m.outbox.begin(), m.outbox.end(), [](const Impl::Outgoing& o) { return o.droppable; });
    if (oldest != m.outbox.end()) {
      m.outbox.erase(oldest);
      ++m.stats.dropped_telemetry;
      break;
    }
    m.cv.wait(lock);  // only messages that must not be lost: wait for acks
  }
  if (m.stopping) return failedPrecondition("link: stopped");
  if (m.next_seq > std::uint64_t(kMaxSeq))
    return failedPrecondition("link: the robot's seqs are used up (the protocol's end at " + std::to_string(kMaxSeq) + ")");
  const std::uint64_t seq = m.enqueueLocked(std::move(j), droppable);
  m.stats.outbox = m.outbox.size();
  lock.unlock();
  net::post(m.ioc, [&m] { m.pump(m.generation); });
  return seq;
}

std::vector<ReceivedCommand> RobotLink::pollCommands() {
  std::lock_guard lock(impl_->mu);
  std::vector<ReceivedCommand> out(impl_->inbox.begin(), impl_->inbox.end());
  impl_->inbox.clear();
  // An e-stop acts before whatever arrived with it: a goal queued ahead of it must not move the
  // robot for one more period. The others keep their order.
  std::stable_partition(out.begin(), out.end(), [](const ReceivedCommand& c) { return c.kind == "estop"; });
  return out;
}

Status RobotLink::answer(std::int64_t command_id, const std::string& result, const std::string& reason, double t_s) {
  if (result != "accepted" && result != "refused" && result != "executed")
    return invalidArgument("command_result: result '" + result + "' is not accepted, refused or executed");
  CommandResult r;
  r.t = std::isfinite(t_s) ? t_s : 0.0;
  r.command_id = command_id;
  r.result = result;
  r.reason = reason;
  const std::string text = toJson(r);
  // Checked before it is kept as the command's answer: a refused answer is not remembered.
  if (Status s = protocol::parseBody(protocol::Json::parse(text)).status(); !s.ok()) return invalidArgument("link: " + s.message());
  if (Status s = protocol::checkSize("command_result", text.size()); !s.ok()) return invalidArgument("link: " + s.message());
  {
    std::lock_guard lock(impl_->mu);
    impl_->answers[command_id] = text;
    impl_->received.insert(command_id);
  }
  return send(text).status();
}

bool RobotLink::flush(double timeout_s) {
  std::unique_lock lock(impl_->mu);
  return impl_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return impl_->outbox.empty(); });
}

LinkStats RobotLink::stats() const {
  std::lock_guard lock(impl_->mu);
  LinkStats s = impl_->stats;
  s.outbox = impl_->outbox.size();
  return s;
}

}  // namespace adit::console
