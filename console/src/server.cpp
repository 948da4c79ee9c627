// SPDX-License-Identifier: BSD-3-Clause
// The console's server: Beast HTTP + WebSocket sessions on one io_context thread. Every Store
// call happens on that thread (the Store is not thread-safe), synchronously inside a handler, so
// a robot message is stored, or refused, before its ack or error is queued.
#include "adit/console/server.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include "protocol.hpp"
#include "web_assets.hpp"

namespace adit::console {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using protocol::Json;
using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

// A robot that never reads its acks must not grow the server's memory either.
constexpr std::size_t kMaxRobotQueue = 4 * kMaxViewerQueue;

void logLine(const std::string& line) { std::fprintf(stderr, "adit serve: %s\n", line.c_str()); }

Json errorJson(const std::string& reason, std::optional<std::int64_t> seq = std::nullopt) {
  Json j = {{"type", "error"}, {"reason", reason}};
  if (seq) j["seq"] = *seq;
  return j;
}

std::string percentDecode(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

std::map<std::string, std::string> parseQuery(const std::string& query) {
  std::map<std::string, std::string> out;
  std::istringstream in(query);
  std::string pair;
  while (std::getline(in, pair, '&')) {
    const auto eq = pair.find('=');
    if (eq == std::string::npos) {
      out[percentDecode(pair)] = "";
    } else {
      out[percentDecode(pair.substr(0, eq))] = percentDecode(pair.substr(eq + 1));
    }
  }
  return out;
}

// Strict non-negative integer (no sign, no spaces, no trailing text, fits int64).
std::optional<std::int64_t> parseCount(const std::string& s) {
  if (s.empty() || s.size() > 18) return std::nullopt;
  for (char c : s)
    if (c < '0' || c > '9') return std::nullopt;
  return std::stoll(s);
}

// Compares without an early exit, so the answer time does not reveal a token's prefix.
bool sameToken(const std::string& a, const std::string& b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned>(a[i] ^ b[i % std::max<std::size_t>(1, b.size())]);
  return diff == 0;
}

StatusOr<std::string> readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound(path + ": cannot read (is libjs-three installed?)");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Json pointJson(const map::Vec3& p) { return Json::array({p.x(), p.y(), p.z()}); }

}  // namespace

class WsSession;

// A token bucket over messages and bytes (RobotQuota's rates). take() spends one message and
// its bytes and answers how long to wait before reading the next: the bucket may go into debt
// by one message (at most kMaxMessageBytes), so nothing is ever refused for the rate, and the
// wait is short (0.25 s for the largest message at the default 1 MiB/s).
class TokenBucket {
 public:
  double take(const RobotQuota& q, std::size_t size, std::chrono::steady_clock::time_point now) {
    if (!started_) {
      messages_ = q.burst_messages;
      bytes_ = q.burst_bytes;
      last_ = now;
      started_ = true;
    }
    const double dt = std::max(0.0, std::chrono::duration<double>(now - last_).count());
    last_ = now;
    messages_ = std::min(q.burst_messages, messages_ + dt * q.messages_per_s) - 1.0;
    bytes_ = std::min(q.burst_bytes, bytes_ + dt * q.bytes_per_s) - double(size);
    return std::max({0.0, -messages_ / q.messages_per_s, -bytes_ / q.bytes_per_s});
  }

 private:
  bool started_ = false;
  double messages_ = 0.0, bytes_ = 0.0;
  std::chrono::steady_clock::time_point last_;
};

struct RobotCache {
  Json telemetry, plan, tracks;
  std::string last_seen;
  std::int64_t stored_seq = 0;  // highest seq known stored (from hello's lastSeq, then each batch)
  // Bytes of bodies stored or on their way (RobotQuota::stored_bytes): read from the Store at
  // the robot's first hello, then counted as fresh messages go to the writer.
  std::optional<std::int64_t> stored_bytes;
  bool over_quota_logged = false;
  TokenBucket bucket;  // the robot's rate, whichever connection it uses
};

// The Store behind a mutex, shared by the I/O thread and the writer thread: `store->call()`
// holds the lock for that one call (the guard lives to the end of the full expression), so the
// Store is used by one thread at a time as store.hpp requires.
class LockedStore {
 public:
  LockedStore(Store& store, std::mutex& mutex) : store_(store), mutex_(mutex) {}
  struct Guard {
    std::unique_lock<std::mutex> lock;
    Store* store;
    Store* operator->() const { return store; }
  };
  Guard operator->() const { return Guard{std::unique_lock<std::mutex>(mutex_), &store_}; }

 private:
  Store& store_;
  std::mutex& mutex_;
};

// A robot message on its way to the database. The writer thread stores the fresh ones of a
// batch in one transaction (group commit: one disk flush for every message that arrived
// meanwhile), then the I/O thread acknowledges and pushes them.
struct PendingMessage {
  enum class Mode { kBatch, kExact, kAckOnly };
  Mode mode = Mode::kBatch;  // kExact: seq <= stored_seq, maybe a resend; kAckOnly: a copy of one in flight
  std::weak_ptr<WsSession> session;
  RobotMessage message;
  Json json;
  std::optional<Command> command;  // for command_result
  bool fresh = false;              // set by the writer
};

struct Server::Impl {
  net::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  std::optional<net::signal_set> signals;
  const map::LoadedMap& loaded;
  const map::DistanceField& field;
  std::mutex store_mutex;
  Store& raw_store;
  LockedStore store{raw_store, store_mutex};
  ServerOptions options;
  map::Aabb bounds;  // where a robot's reported points may be: the map's, kMapBoundsMargin wider
  std::map<std::string, std::pair<std::string, std::string>> assets;  // path -> (content type, bytes)
  std::string map_json, mesh_json;
  std::set<std::string> roadways;
  std::map<std::string, RobotCache> cache;
  std::map<std::string, std::weak_ptr<WsSession>> robot_sessions;
  std::map<WsSession*, std::weak_ptr<WsSession>> viewers;
  // The writer thread and its queue (guarded by queue_mutex).
  std::thread writer;
  std::mutex queue_mutex;
  std::condition_variable queue_cv;
  std::vector<PendingMessage> queue;
  bool stopping = false;
  std::set<std::pair<std::string, std::int64_t>> in_flight;  // I/O thread only

  void startWriter();
  void stopWriter();
  void writeLoop();
  void finish(std::vector<PendingMessage> done, const Status& status);

  Impl(const map::LoadedMap& l, const map::DistanceField& f, Store& s, ServerOptions o)
      : loaded(l), field(f), raw_store(s), options(std::move(o)), bounds(l.map.bounds().inflated(kMapBoundsMargin)) {}
  ~Impl() { stopWriter(); }

  Status prepare();
  void accept();
  Response handle(const Request& req);
  Response handleCommandPost(const Request& req);
  /// A WebSocket upgrade's Origin and credential (console/doc/protocol.md, "Who may connect");
  /// the refusal to send, or nothing and `*credential_robot` set (empty: the operator token).
  std::optional<Response> authorizeUpgrade(const Request& req, bool robot, std::string* credential_robot);
  /// The 401 answer unless `req` carries the operator token in its Authorization header.
  std::optional<Response> requireOperator(const Request& req) const;
  void onRobotText(WsSession& session, const std::string& text);
  double throttle(WsSession& session, std::size_t bytes);
  void onViewerOpen(const std::shared_ptr<WsSession>& session);
  void broadcast(const Json& message, bool telemetry);
  void deliver(Command command);
  void setCommandStatus(Command command, CommandStatus status, const std::string& reason);
  Json robotsJson();
  void warmCache();
};

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

namespace {

Response jsonResponse(const Request& req, http::status status, const std::string& body) {
  Response res{status, req.version()};
  res.set(http::field::content_type, "application/json");
  res.set(http::field::cache_control, "no-store");
  res.keep_alive(req.keep_alive());
  res.body() = body;
  res.prepare_payload();
  return res;
}

Response refusal(const Request& req, http::status status, const std::string& reason) {
  return jsonResponse(req, status, Json{{"error", reason}}.dump());
}

}  // namespace

Status Server::Impl::prepare() {
  for (const auto& [name, content] : webAssets()) {
    std::string type = "application/octet-stream";
    if (name.size() > 5 && name.compare(name.size() - 5, 5, ".html") == 0) type = "text/html; charset=utf-8";
    if (name.size() > 3 && name.compare(name.size() - 3, 3, ".js") == 0) type = "text/javascript; charset=utf-8";
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".css") == 0) type = "text/css; charset=utf-8";
    assets[name == "index.html" ? "/" : "/assets/" + name] = {type, content};
  }
  // three.js comes from Debian's libjs-three at run time: the package is a dependency anyway,
  // its security updates then reach the console without a rebuild, and the binary stays small.
  ADIT_ASSIGN_OR_RETURN(std::string three, readWholeFile(options.three_dir + "/three.min.js"));
  ADIT_ASSIGN_OR_RETURN(std::string orbit, readWholeFile(options.three_dir + "/examples/js/controls/OrbitControls.js"));
  assets["/assets/three.min.js"] = {"text/javascript; charset=utf-8", std::move(three)};
  assets["/assets/OrbitControls.js"] = {"text/javascript; charset=utf-8", std::move(orbit)};

  const map::OccupancyMap& m = loaded.map;
  Json roadway_list = Json::array();
  if (loaded.survey) {
    for (const map::SurveyRoadway& r : loaded.survey->roadways) {
      Json line = Json::array();
      for (const map::Vec3& p : loaded.survey->centreline(r).points) line.push_back(pointJson(p));
      const auto section = loaded.survey->sections.find(r.section);
      const double width = section == loaded.survey->sections.end() ? 0.0 : section->second.maxWidth();
      roadway_list.push_back({{"name", r.name}, {"centreline", line}, {"width", width}});
      roadways.insert(r.name);
    }
  }
  map_json = Json{{"name", options.map_name},
                  {"hash", options.map_hash},
                  {"resolution", m.stats().resolution_m},
                  {"bounds", {{"min", pointJson(m.bounds().min)}, {"max", pointJson(m.bounds().max)}}},
                  {"roadways", roadway_list}}
                 .dump();
  ADIT_ASSIGN_OR_RETURN(RoadwayMesh mesh, buildRoadwayMesh(m, options.mesh_cell));
  mesh_json = Json{{"cell", mesh.cell}, {"positions", mesh.positions}, {"normals", mesh.normals}, {"indices", mesh.indices}}
                  .dump();
  warmCache();
  return Status::okStatus();
}

// A restarted centre shows what it had: the last telemetry, plan and tracks of every robot, each
// its newest stored message of that type. (It used to page backwards through the seqs 5,000 at a
// time: a robot that had sent seq 2^63 - 1 kept a restart busy for ever.)
void Server::Impl::warmCache() {
  auto robots = store->robots();
  if (!robots.ok()) return;
  for (const RobotRecord& r : *robots) {
    RobotCache& c = cache[r.robot];
    c.last_seen = r.last_seen;
    c.stored_seq = r.last_seq;
    for (const char* type : {"telemetry", "plan", "obstacles"}) {
      auto m = store->lastOfType(r.robot, type);
      if (!m.ok() || !*m) continue;
      Json j = Json::parse((*m)->body, nullptr, false);
      if (!j.is_object()) continue;
      j["received_at"] = (*m)->received_at;
      if ((*m)->type == "telemetry") c.telemetry = j;
      else if ((*m)->type == "plan") c.plan = j;
      else c.tracks = j.value("tracks", Json::array());
    }
  }
}

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

void Server::Impl::broadcast(const Json& message, bool telemetry) {
  const auto text = std::make_shared<const std::string>(message.dump());
  for (auto it = viewers.begin(); it != viewers.end();) {
    auto v = it->second.lock();
    if (!v || v->dead()) {
      it = viewers.erase(it);
      continue;
    }
    v->send(text, telemetry);
    ++it;
  }
}

void Server::Impl::setCommandStatus(Command command, CommandStatus status, const std::string& reason) {
  command.status = status;
  command.reason = reason;
  command.updated_at = protocol::isoNow();
  const Status s = store->updateCommand(command.command_id, status, reason, command.updated_at);
  if (!s.ok()) {
    logLine("database: " + s.message());
    return;
  }
  broadcast(protocol::commandState(command), false);
}

// Sends the command to its robot if connected; a pending one becomes `sent`.
void Server::Impl::deliver(Command command) {
  auto it = robot_sessions.find(command.robot);
  if (it == robot_sessions.end()) return;
  auto session = it->second.lock();
  if (!session || session->dead()) return;
  session->send(protocol::commandMessage(command));
  if (command.status == CommandStatus::kPending) setCommandStatus(command, CommandStatus::kSent, "");
}

double Server::Impl::throttle(WsSession& session, std::size_t bytes) {
  TokenBucket& bucket = session.robotId().empty() ? session.ownBucket() : cache[session.robotId()].bucket;
  return bucket.take(options.quota, bytes, std::chrono::steady_clock::now());
}

void Server::Impl::onRobotText(WsSession& session, const std::string& text) {
  StatusOr<Json> parsed = protocol::parseObject(text);
  if (!parsed.ok()) {
    session.send(errorJson(parsed.status().message()));
    // Not JSON at all: the stream is out of step, start over; a JSON non-object is an error only.
    if (parsed.status().message() == protocol::kMalformedJson) session.closeAfterWrites(websocket::close_code::bad_payload);
    return;
  }
  const Json& j = *parsed;
  std::optional<std::int64_t> seq;
  if (j.contains("seq") && j["seq"].is_number_integer()) seq = j["seq"].get<std::int64_t>();
  const std::string type = j.contains("type") && j["type"].is_string() ? j["type"].get<std::string>() : "";
  if (type == "hello") {
    StatusOr<protocol::Hello> hello = protocol::parseHello(j);
    if (!hello.ok()) {
      session.send(errorJson(hello.status().message()));
      return;
    }
    if (!session.credentialRobot().empty() && hello->robot != session.credentialRobot()) {
      logLine("refused hello as robot '" + hello->robot + "' from a connection with the credential of '" +
              session.credentialRobot() + "'");
      session.send(errorJson("this connection's credential is robot '" + session.credentialRobot() + "'s, not '" +
                             hello->robot + "'s"));
      session.closeAfterWrites(websocket::close_code::policy_error);
      return;
    }
    if (!session.robotId().empty() && hello->robot != session.robotId()) {
      session.send(errorJson("this connection is robot '" + session.robotId() + "'; a connection speaks for one robot"));
      session.closeAfterWrites(websocket::close_code::policy_error);
      return;
    }
    if (hello->map_hash != options.map_hash) {
      session.send(errorJson("map_hash " + hello->map_hash + " is not the served map's " + options.map_hash));
      session.closeAfterWrites(websocket::close_code::policy_error);
      return;
    }
    const std::string now = protocol::isoNow();
    Status s = store->upsertRobot({hello->robot, hello->map_hash, hello->radius, now, now, 0});
    StatusOr<std::int64_t> acked = s.ok() ? store->lastSeq(hello->robot) : StatusOr<std::int64_t>(s);
    StatusOr<std::vector<Command>> unanswered =
        acked.ok() ? store->unansweredCommands(hello->robot) : StatusOr<std::vector<Command>>(acked.status());
    if (unanswered.ok() && !cache[hello->robot].stored_bytes) {
      StatusOr<std::int64_t> bytes = store->storedBytes(hello->robot);
      if (bytes.ok()) cache[hello->robot].stored_bytes = *bytes;
      else unanswered = bytes.status();
    }
    if (!unanswered.ok()) {
      logLine("database: " + unanswered.status().message());
      session.send(errorJson("database: " + unanswered.status().message()));
      return;
    }
    session.bind(hello->robot, hello->radius);
    // An authenticated newer connection of the same robot replaces the older one (a reconnect
    // after a half-open drop): the older is closed, so commands never go to two connections.
    if (auto older = robot_sessions[hello->robot].lock(); older && older.get() != &session && !older->dead()) {
      logLine("robot " + hello->robot + ": a new connection replaces the older one");
      older->send(errorJson("replaced by a newer connection of robot '" + hello->robot + "'"));
      older->closeAfterWrites(websocket::close_code::policy_error);
    }
    robot_sessions[hello->robot] = session.shared_from_this();
    cache[hello->robot].last_seen = now;
    cache[hello->robot].stored_seq = std::max(cache[hello->robot].stored_seq, *acked);
    session.send(Json{{"type", "welcome"}, {"robot", hello->robot}, {"acked_seq", *acked}});
    for (const Command& c : *unanswered) deliver(c);
    return;
  }
  if (session.robotId().empty()) {
    session.refuse("send hello first", seq);
    return;
  }
  StatusOr<RobotMessage> message = protocol::parseRobotMessage(j);
  if (!message.ok()) {
    session.refuse(message.status().message(), seq);
    return;
  }
  if (message->robot != session.robotId()) {
    session.refuse("unknown robot '" + message->robot + "' (this connection is '" + session.robotId() + "')", seq);
    return;
  }
  std::optional<Command> command;
  if (message->type == "command_result") {
    const protocol::CommandResult r = protocol::commandResultOf(j);
    StatusOr<std::optional<Command>> c = store->command(r.command_id);
    if (c.ok() && (!*c || (*c)->robot != message->robot)) {
      session.refuse("unknown command_id " + std::to_string(r.command_id) + " for robot " + message->robot, seq);
      return;
    }
    if (c.ok()) command = **c;
  }
  message->body = text;
  message->received_at = protocol::isoNow();
  RobotCache& rc = cache[message->robot];
  // A seq far beyond what is stored is not a robot's next message (they come in order, at most
  // an outbox ahead): refused, so that one message cannot use up the robot's seq range.
  if (message->seq > rc.stored_seq + kMaxSeqGap) {
    session.refuse("seq " + std::to_string(message->seq) + " is more than " + std::to_string(kMaxSeqGap) +
                               " beyond the last stored (" + std::to_string(rc.stored_seq) + ")",
                           seq);
    return;
  }
  if (Status size = protocol::checkSize(message->type, text.size()); !size.ok()) {
    session.refuse(size.message(), seq);
    return;
  }
  if (Status within = protocol::checkWithin(j, bounds); !within.ok()) {
    session.refuse(within.message(), seq);
    return;
  }
  const auto key = std::make_pair(message->robot, message->seq);
  const bool fresh = !in_flight.count(key) && message->seq > rc.stored_seq;
  const std::int64_t size = static_cast<std::int64_t>(text.size());
  if (fresh && rc.stored_bytes && *rc.stored_bytes + size > options.quota.stored_bytes) {
    if (!rc.over_quota_logged) {
      rc.over_quota_logged = true;
      logLine("robot " + message->robot + " reached its stored-bytes quota (" +
              std::to_string(options.quota.stored_bytes) + " bytes): its new messages are refused");
    }
    session.refuse("robot '" + message->robot + "' has " + std::to_string(*rc.stored_bytes) +
                               " bytes stored; this message would pass its quota of " +
                               std::to_string(options.quota.stored_bytes) + " (adit serve --robot-store-quota)",
                           seq);
    return;
  }
  if (Status time = session.checkTime(message->seq, message->t); !time.ok()) {
    session.refuse(time.message(), seq);
    return;
  }
  rc.last_seen = message->received_at;
  PendingMessage p;
  if (in_flight.count(key)) {
    p.mode = PendingMessage::Mode::kAckOnly;
  } else if (message->seq <= rc.stored_seq) {
    p.mode = PendingMessage::Mode::kExact;
  } else {
    in_flight.insert(key);
    if (rc.stored_bytes) *rc.stored_bytes += size;
  }
  p.session = session.shared_from_this();
  p.message = std::move(*message);
  p.json = j;
  p.command = std::move(command);
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    queue.push_back(std::move(p));
  }
  queue_cv.notify_one();
}

void Server::Impl::startWriter() {
  writer = std::thread([this] { writeLoop(); });
}

void Server::Impl::stopWriter() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    stopping = true;
  }
  queue_cv.notify_one();
  if (writer.joinable()) writer.join();
}

// The writer thread: takes everything queued, stores the new messages in one transaction and
// re-checks possible resends one by one, then hands the outcome to the I/O thread.
void Server::Impl::writeLoop() {
  for (;;) {
    std::vector<PendingMessage> batch;
    {
      std::unique_lock<std::mutex> lock(queue_mutex);
      queue_cv.wait(lock, [this] { return stopping || !queue.empty(); });
      if (stopping) return;  // queued but unstored: never acknowledged, the robots resend
      batch.swap(queue);
    }
    std::vector<RobotMessage> fresh;
    for (const PendingMessage& p : batch)
      if (p.mode == PendingMessage::Mode::kBatch) fresh.push_back(p.message);
    Status status = Status::okStatus();
    if (!fresh.empty()) {
      StatusOr<std::size_t> n = store->appendMessages(fresh);
      if (!n.ok()) {
        status = n.status();
      } else if (*n != fresh.size()) {  // another centre on the same database stored some
        logLine("database: " + std::to_string(fresh.size() - *n) + " of a batch were stored already");
      }
    }
    for (PendingMessage& p : batch) {
      p.fresh = p.mode == PendingMessage::Mode::kBatch && status.ok();
      if (p.mode != PendingMessage::Mode::kExact || !status.ok()) continue;
      StatusOr<bool> one = store->appendMessage(p.message);
      if (!one.ok()) {
        status = one.status();
        continue;
      }
      p.fresh = *one;
    }
    net::post(ioc, [this, done = std::move(batch), status]() mutable { finish(std::move(done), status); });
  }
}

// On the I/O thread: ack what is stored (an error for what is not: the robot keeps it and
// resends), push the new messages to the viewers, record command results.
void Server::Impl::finish(std::vector<PendingMessage> done, const Status& status) {
  if (!status.ok()) logLine("database: " + status.message());
  for (PendingMessage& p : done) {
    const RobotMessage& m = p.message;
    if (p.mode == PendingMessage::Mode::kBatch) in_flight.erase({m.robot, m.seq});
    auto session = p.session.lock();
    if (!status.ok()) {
      if (session) session->send(errorJson("database: " + status.message(), m.seq));
      continue;
    }
    if (session) session->send(Json{{"type", "ack"}, {"seq", m.seq}});
    if (!p.fresh) continue;
    RobotCache& c = cache[m.robot];
    c.stored_seq = std::max(c.stored_seq, m.seq);
    Json& stored = p.json;
    stored["received_at"] = m.received_at;
    if (m.type == "telemetry") c.telemetry = stored;
    if (m.type == "plan") c.plan = stored;
    if (m.type == "obstacles") c.tracks = stored.value("tracks", Json::array());
    broadcast(stored, m.type == "telemetry");
    if (p.command) {
      // A robot answers a command it got again with its stored result: never step back
      // (executed stays executed when an `accepted` repeat arrives).
      const protocol::CommandResult r = protocol::commandResultOf(stored);
      Command now = *p.command;  // its state when the result was queued; re-read, results may batch
      if (auto current = store->command(now.command_id); current.ok() && *current) now = **current;
      if (static_cast<int>(r.status) >= static_cast<int>(now.status)) setCommandStatus(now, r.status, r.reason);
    }
  }
}

Json Server::Impl::robotsJson() {
  Json out = Json::array();
  auto robots = store->robots();
  if (!robots.ok()) return out;
  for (const RobotRecord& r : *robots) {
    const RobotCache& c = cache[r.robot];
    out.push_back({{"robot", r.robot},
                   {"last_seq", r.last_seq},
                   {"last_seen", c.last_seen.empty() ? r.last_seen : c.last_seen},
                   {"radius", r.radius},
                   {"telemetry", c.telemetry},
                   {"plan", c.plan},
                   {"tracks", c.tracks.is_null() ? Json::array() : c.tracks}});
  }
  return out;
}

void Server::Impl::onViewerOpen(const std::shared_ptr<WsSession>& session) {
  Json commands = Json::array();
  if (auto list = store->commands("", 100); list.ok())
    for (const Command& c : *list) commands.push_back(protocol::commandState(c));
  session->send(Json{{"type", "snapshot"}, {"robots", robotsJson()}, {"commands", commands}});
  viewers[session.get()] = session;
}

namespace {

// The request's credential: `Authorization: Bearer TOKEN`, else (for a browser's WebSocket,
// which cannot set headers) `?token=TOKEN` in the target when `query_allowed`.
std::string credentialOf(const Request& req, bool query_allowed) {
  const auto auth = req.find(http::field::authorization);
  const std::string bearer = "Bearer ";
  if (auth != req.end()) {
    const std::string value(auth->value());
    return value.size() > bearer.size() && value.compare(0, bearer.size(), bearer) == 0 ? value.substr(bearer.size())
                                                                                       : std::string();
  }
  if (!query_allowed) return std::string();
  const std::string target(req.target());
  const auto q = target.find('?');
  if (q == std::string::npos) return std::string();
  const auto query = parseQuery(target.substr(q + 1));
  const auto it = query.find("token");
  return it == query.end() ? std::string() : it->second;
}

// "http://HOST" or "https://HOST" for the request's Host header: the page's own origin.
bool sameOrigin(const std::string& origin, const Request& req) {
  const auto host = req.find(http::field::host);
  if (host == req.end() || host->value().empty()) return false;
  const std::string h(host->value());
  return origin == "http://" + h || origin == "https://" + h;
}

}  // namespace

std::optional<Response> Server::Impl::authorizeUpgrade(const Request& req, bool robot, std::string* credential_robot) {
  const char* const route = robot ? "/ws/robot" : "/ws/view";
  // A browser always sends Origin; a page on another site must not reach the robots or the mine
  // through the operator's browser (cross-site WebSocket hijacking). Robots are not browsers and
  // send none.
  if (const auto origin = req.find(http::field::origin); origin != req.end()) {
    const std::string o(origin->value());
    const bool allowed = sameOrigin(o, req) || std::find(options.allowed_origins.begin(), options.allowed_origins.end(),
                                                         o) != options.allowed_origins.end();
    if (!allowed) {
      logLine(std::string("refused a WebSocket on ") + route + " from origin '" + o.substr(0, 200) + "'");
      return refusal(req, http::status::forbidden,
                     "origin '" + o.substr(0, 200) + "' may not open " + route + " (adit serve --allow-origin)");
    }
  }
  const std::string credential = credentialOf(req, /*query_allowed=*/true);
  if (!credential.empty() && sameToken(credential, options.token)) {
    credential_robot->clear();  // the operator token speaks for any robot
    return std::nullopt;
  }
  if (robot && !credential.empty())
    for (const auto& [id, token] : options.robot_tokens)
      if (sameToken(credential, token)) {
        *credential_robot = id;
        return std::nullopt;
      }
  logLine(std::string("refused a WebSocket on ") + route + ": " + (credential.empty() ? "no" : "a wrong") + " credential");
  return refusal(req, http::status::unauthorized,
                 std::string(credential.empty() ? "missing" : "wrong") + " credential for " + route + " (" +
                     (robot ? "the robot's token or the operator token" : "the operator token") +
                     ": Authorization: Bearer TOKEN, or ?token=TOKEN)");
}

std::optional<Response> Server::Impl::requireOperator(const Request& req) const {
  const std::string credential = credentialOf(req, /*query_allowed=*/false);
  if (!credential.empty() && sameToken(credential, options.token)) return std::nullopt;
  return refusal(req, http::status::unauthorized, "missing or wrong operator token (Authorization: Bearer TOKEN)");
}

Response Server::Impl::handleCommandPost(const Request& req) {
  if (std::optional<Response> refused = requireOperator(req)) return *refused;
  StatusOr<Json> body = protocol::parseObject(req.body());
  if (!body.ok()) return refusal(req, http::status::bad_request, body.status().message());
  StatusOr<protocol::CommandRequest> cmd = protocol::parseCommandRequest(*body);
  if (!cmd.ok()) return refusal(req, http::status::bad_request, cmd.status().message());
  StatusOr<std::optional<RobotRecord>> robot = store->robot(cmd->robot);
  if (!robot.ok()) return refusal(req, http::status::internal_server_error, "database: " + robot.status().message());
  if (!*robot) return refusal(req, http::status::not_found, "unknown robot '" + cmd->robot + "'");
  const auto unprocessable = http::status::unprocessable_entity;
  Json args = Json::object();
  if (cmd->goal) {
    const map::Vec3 g = *cmd->goal;
    char where[96];
    std::snprintf(where, sizeof where, "goal (%.2f, %.2f, %.2f)", g.x(), g.y(), g.z());
    if (!loaded.map.bounds().contains(g)) return refusal(req, unprocessable, std::string(where) + " is outside the map");
    if (!field.isFree(g)) return refusal(req, unprocessable, std::string(where) + " is in rock");
    const double clearance = field.distance(g);
    if (clearance < (*robot)->radius) {
      char why[160];
      std::snprintf(why, sizeof why, "%s has %.2f m clearance, less than the robot's radius %.2f m", where, clearance,
                    (*robot)->radius);
      return refusal(req, unprocessable, why);
    }
    args["goal"] = pointJson(g);
  }
  if (cmd->kind == "block" || cmd->kind == "reopen") {
    if (!roadways.count(cmd->roadway)) return refusal(req, unprocessable, "unknown roadway '" + cmd->roadway + "'");
    args["roadway"] = cmd->roadway;
  }
  if (cmd->velocity) {
    if (cmd->velocity->norm() > kMaxManualSpeed) {
      char why[96];
      std::snprintf(why, sizeof why, "speed %.2f m/s is above %.1f m/s", cmd->velocity->norm(), kMaxManualSpeed);
      return refusal(req, unprocessable, why);
    }
    args["velocity"] = pointJson(*cmd->velocity);
  }
  StatusOr<std::vector<Command>> pending = store->unansweredCommands(cmd->robot);
  if (!pending.ok()) return refusal(req, http::status::internal_server_error, "database: " + pending.status().message());
  if (pending->size() >= kMaxPendingCommands)
    return refusal(req, http::status::too_many_requests,
                   std::to_string(pending->size()) + " commands of " + cmd->robot + " are still unanswered");
  Command c;
  c.robot = cmd->robot;
  c.operator_name = options.operator_name;
  c.issued_at = c.updated_at = protocol::isoNow();
  c.kind = cmd->kind;
  c.body = args.dump();
  StatusOr<std::int64_t> id = store->addCommand(c);
  if (!id.ok()) return refusal(req, http::status::internal_server_error, "database: " + id.status().message());
  c.command_id = *id;
  broadcast(protocol::commandState(c), false);
  deliver(c);
  return jsonResponse(req, http::status::accepted, Json{{"command_id", *id}, {"status", "pending"}}.dump());
}

Response Server::Impl::handle(const Request& req) {
  const std::string target(req.target());
  const auto q = target.find('?');
  const std::string path = target.substr(0, q);
  const auto query = parseQuery(q == std::string::npos ? "" : target.substr(q + 1));
  const bool get = req.method() == http::verb::get || req.method() == http::verb::head;
  if (path == "/api/commands" && req.method() == http::verb::post) return handleCommandPost(req);
  auto asset = assets.find(path);
  const bool known = asset != assets.end() || path.rfind("/api/", 0) == 0;
  if (known && !get) return refusal(req, http::status::method_not_allowed, req.method_string().to_string() + " " + path);
  if (asset != assets.end()) {
    Response res{http::status::ok, req.version()};
    res.set(http::field::content_type, asset->second.first);
    if (path == "/")  // the page fetches from its own server only: no CDN, works offline
      res.set("Content-Security-Policy",
              "default-src 'self'; connect-src 'self' ws: ; img-src 'self' data:; style-src 'self'");
    res.keep_alive(req.keep_alive());
    res.body() = asset->second.second;
    res.prepare_payload();
    return res;
  }
  // Reading the mine needs the operator token as commanding it does (the page sends it); only
  // the health check is open, for monitoring.
  if (path != "/api/health") {
    if (std::optional<Response> refused = requireOperator(req)) return *refused;
  }
  if (path == "/api/health") {
    StatusOr<int> version = store->schemaVersion();
    if (!version.ok()) return refusal(req, http::status::internal_server_error, "database: " + version.status().message());
    std::size_t robots = 0, viewing = 0;
    for (const auto& [id, s] : robot_sessions) {
      auto p = s.lock();
      robots += p && !p->dead();
    }
    for (const auto& [ptr, s] : viewers) {
      auto p = s.lock();
      viewing += p && !p->dead();
    }
    return jsonResponse(req, http::status::ok,
                        Json{{"ok", true}, {"schema_version", *version}, {"db", store->backend()}, {"robots", robots},
                             {"viewers", viewing}}
                            .dump());
  }
  if (path == "/api/map") return jsonResponse(req, http::status::ok, map_json);
  if (path == "/api/map/mesh") return jsonResponse(req, http::status::ok, mesh_json);
  if (path == "/api/robots") return jsonResponse(req, http::status::ok, robotsJson().dump());
  if (path == "/api/commands") {
    const std::string robot = query.count("robot") ? query.at("robot") : "";
    if (!robot.empty() && !protocol::validRobotId(robot))
      return refusal(req, http::status::bad_request, protocol::kBadRobotId);
    auto list = store->commands(robot, 10000);
    if (!list.ok()) return refusal(req, http::status::internal_server_error, "database: " + list.status().message());
    Json out = Json::array();
    for (const Command& c : *list) out.push_back(protocol::commandState(c));
    return jsonResponse(req, http::status::ok, out.dump());
  }
  if (path == "/api/history") {
    if (!query.count("robot")) return refusal(req, http::status::bad_request, "missing parameter 'robot'");
    const std::string robot = query.at("robot");
    if (!protocol::validRobotId(robot))
      return refusal(req, http::status::bad_request, protocol::kBadRobotId);
    std::optional<std::int64_t> from = query.count("from_seq") ? parseCount(query.at("from_seq")) : 1;
    std::optional<std::int64_t> limit = query.count("limit") ? parseCount(query.at("limit")) : 1000;
    if (!from) return refusal(req, http::status::bad_request, "from_seq must be a non-negative integer");
    if (!limit || *limit < 1 || *limit > 10000)
      return refusal(req, http::status::bad_request, "limit must be an integer from 1 to 10000");
    auto record = store->robot(robot);
    if (!record.ok()) return refusal(req, http::status::internal_server_error, "database: " + record.status().message());
    if (!*record) return refusal(req, http::status::not_found, "unknown robot '" + robot + "'");
    auto msgs = store->history(robot, *from, static_cast<std::size_t>(*limit));
    if (!msgs.ok()) return refusal(req, http::status::internal_server_error, "database: " + msgs.status().message());
    Json out = Json::array();
    for (const RobotMessage& m : *msgs) {
      Json j = Json::parse(m.body, nullptr, false);
      if (!j.is_object()) continue;
      j["received_at"] = m.received_at;
      out.push_back(std::move(j));
    }
    return jsonResponse(req, http::status::ok, out.dump());
  }
  return refusal(req, http::status::not_found, "no such path: " + path);
}

Status RobotQuota::validate() const {
  // Finite and positive, and a burst that holds the largest message: else a robot's one
  // message could wait forever for tokens the bucket never holds.
  if (!(messages_per_s > 0.0) || !std::isfinite(messages_per_s)) return invalidArgument("--robot-rate must be > 0 messages/s");
  if (!(bytes_per_s > 0.0) || !std::isfinite(bytes_per_s)) return invalidArgument("--robot-bandwidth must be > 0 bytes/s");
  if (!(burst_messages >= 1.0) || !std::isfinite(burst_messages)) return invalidArgument("a robot's burst must be >= 1 message");
  if (!(burst_bytes >= double(kMaxMessageBytes)) || !std::isfinite(burst_bytes))
    return invalidArgument("a robot's byte burst must hold one message (" + std::to_string(kMaxMessageBytes) + " bytes)");
  if (stored_bytes < std::int64_t{1} << 20) return invalidArgument("--robot-store-quota must be at least 1 MiB");
  return Status::okStatus();
}

Status ServerOptions::validate() const {
  if (token.empty()) return invalidArgument("the operator token is empty");
  for (char c : token)
    if (std::isspace(static_cast<unsigned char>(c))) return invalidArgument("the operator token contains white space");
  if (operator_name.empty()) return invalidArgument("the operator name is empty");
  if (map_hash.empty()) return invalidArgument("the map hash is empty");
  if (!(mesh_cell >= 0.0)) return invalidArgument("mesh cell must be >= 0");
  if (viewer_queue_bytes < (std::size_t{1} << 20)) return invalidArgument("a viewer's queue must hold at least 1 MiB");
  ADIT_RETURN_IF_ERROR(quota.validate());
  for (const std::string& o : allowed_origins) {
    const auto scheme = o.find("://");
    if (scheme == std::string::npos || scheme == 0 || scheme + 3 == o.size() || o.back() == '/' ||
        o.find_first_of(" \t/", scheme + 3) != std::string::npos)
      return invalidArgument("--allow-origin '" + o + "': expected SCHEME://HOST[:PORT], e.g. https://ops.example:8443");
  }
  std::set<std::string> tokens{token};
  for (const auto& [id, t] : robot_tokens) {
    if (!protocol::validRobotId(id)) return invalidArgument("robot token for '" + id + "': not a valid robot id");
    if (t.size() < kMinTokenLength) return invalidArgument("robot token for '" + id + "': shorter than 16 characters");
    if (!tokens.insert(t).second)
      return invalidArgument("robot token for '" + id + "': the same as another robot's or the operator's");
  }
  return Status::okStatus();
}

StatusOr<std::map<std::string, std::string>> parseRobotTokens(const std::string& text, const std::string& file) {
  std::map<std::string, std::string> out;
  std::set<std::string> seen_tokens;
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string id, token, extra;
    fields >> id >> token;
    const std::string at = file + ":" + std::to_string(n) + ": ";
    if (token.empty() || (fields >> extra)) return invalidArgument(at + "expected ROBOT_ID TOKEN");
    if (!protocol::validRobotId(id)) return invalidArgument(at + "'" + id.substr(0, 80) + "' is not a valid robot id");
    if (token.size() < kMinTokenLength) return invalidArgument(at + "the token is shorter than 16 characters");
    if (out.count(id)) return invalidArgument(at + "robot '" + id + "' again");
    if (!seen_tokens.insert(token).second) return invalidArgument(at + "the same token as an earlier robot's");
    out[id] = token;
  }
  return out;
}

Status parseListen(const std::string& listen, ServerOptions* options) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0)
    return invalidArgument("--listen '" + listen + "': expected HOST:PORT, e.g. 127.0.0.1:8080");
  std::string host = listen.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const auto port = parseCount(listen.substr(colon + 1));
  if (!port || *port > 65535) return invalidArgument("--listen '" + listen + "': the port must be 0-65535");
  beast::error_code ec;
  net::ip::make_address(host, ec);
  if (ec) return invalidArgument("--listen '" + listen + "': '" + host + "' is not an IP address");
  options->address = host;
  options->port = static_cast<unsigned short>(*port);
  return Status::okStatus();
}

Server::Server(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Server::~Server() = default;

StatusOr<std::unique_ptr<Server>> Server::create(const map::LoadedMap& loaded, const map::DistanceField& field,
                                                 Store& store, ServerOptions options) {
  ADIT_RETURN_IF_ERROR(options.validate());
  auto impl = std::make_unique<Impl>(loaded, field, store, std::move(options));
  ADIT_RETURN_IF_ERROR(impl->prepare());
  beast::error_code ec;
  const tcp::endpoint endpoint(net::ip::make_address(impl->options.address, ec), impl->options.port);
  if (ec) return invalidArgument("listen address '" + impl->options.address + "': " + ec.message());
  impl->acceptor.open(endpoint.protocol(), ec);
  if (!ec) impl->acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) impl->acceptor.bind(endpoint, ec);
  if (!ec) impl->acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    return failedPrecondition("cannot listen on " + impl->options.address + ":" + std::to_string(impl->options.port) +
                              ": " + ec.message());
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

unsigned short Server::port() const { return impl_->acceptor.local_endpoint().port(); }

Status Server::run() {
  Impl& d = *impl_;
  if (d.options.stop_on_signals) {
    d.signals.emplace(d.ioc, SIGINT, SIGTERM);
    d.signals->async_wait([this](beast::error_code ec, int) {
      if (!ec) stop();
    });
  }
  d.startWriter();
  d.accept();
  d.ioc.run();
  d.stopWriter();
  return Status::okStatus();
}

void Server::stop() {
  Impl& d = *impl_;
  net::post(d.ioc, [&d] {
    beast::error_code ignored;
    d.acceptor.close(ignored);
    if (d.signals) d.signals->cancel(ignored);
    d.ioc.stop();
  });
}

}  // namespace adit::console
