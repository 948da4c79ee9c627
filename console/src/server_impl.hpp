// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The console server's shared state (console/src/server*.cpp, transport.cpp, routes.cpp,
// robot_stream.cpp, writer.cpp): Server::Impl and what it holds. One io_context thread runs
// every handler; the writer thread stores robot messages (writer.cpp). Internal: not installed.

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

namespace adit::console {

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

void logLine(const std::string& line);
Json errorJson(const std::string& reason, std::optional<std::int64_t> seq = std::nullopt);
Json pointJson(const map::Vec3& p);
/// Strict non-negative integer (no sign, no spaces, no trailing text, fits int64).
std::optional<std::int64_t> parseCount(const std::string& s);

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
  // The robot's e-stop from the moment it is issued until an estop_release is executed (its
  // command's state says whether the robot has acknowledged it).
  std::optional<Command> estop;
  // Alarms (alarms.cpp): the id of each kind's uncleared alarm, and what the stale check needs.
  std::map<std::string, std::int64_t> raised;
  // Raised alarms whose condition has ended, since when: cleared once it stays ended for
  // kAlarmSettle (alarms.cpp), so a flapping condition is one alarm, not a row per message.
  std::map<std::string, std::chrono::steady_clock::time_point> ending;
  std::optional<std::chrono::steady_clock::time_point> telemetry_at;  // the last telemetry's arrival
  double declared_period = 0.0;   // the robot's `period`, 0: none
  double estimated_period = 0.0;  // a running mean of the arrival intervals
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
  protocol::Body body;  // message as its type
  Json json;            // and as received, for viewers
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
  net::steady_timer alarm_timer{ioc};
  std::map<std::int64_t, Alarm> open_alarms;  // raised and not both cleared and acknowledged

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

  // E-stops (routes.cpp, robot_stream.cpp): an e-stop for every known robot; a command's state
  // change as the robot's e-stop state, pushed as {"type": "estop"}.
  Response handleEstopAll(const Request& req);
  /// Stores an operator's command, shows it to the viewers and sends it to its robot if
  /// connected (else at its next hello); its id.
  StatusOr<std::int64_t> issueCommand(const std::string& robot, const std::string& kind, const std::string& args);
  void noteEstop(const Command& c);
  static Json estopJson(const std::optional<Command>& estop);

  // Alarms (alarms.cpp).
  void startAlarmTimer();
  void checkStale();
  void raiseAlarm(const std::string& robot, const std::string& kind, const std::string& message);
  /// The condition has ended: the alarm clears once it stays ended for kAlarmSettle.
  void endAlarm(const std::string& robot, const std::string& kind);
  void clearAlarm(const std::string& robot, const std::string& kind);
  void clearSettled();
  void onTelemetryArrived(const std::string& robot, const Telemetry& m);
  void onTelemetryStored(const std::string& robot, const Telemetry& m);
  void onRobotClosed(WsSession& session);
  void warmAlarms();
  Json openAlarmsJson() const;
  Response handleAlarmAck(const Request& req);
  Response handleAlarmsGet(const Request& req, const std::map<std::string, std::string>& query);
};

/// An alarm as listed by GET /api/alarms and pushed to viewers as {"type": "alarm", ...}.
Json alarmJson(const Alarm& a);
/// The protocol's alarm kinds and their severities (console/doc/protocol.md, "Alarms").
const char* alarmSeverity(const std::string& kind);

}  // namespace adit::console
