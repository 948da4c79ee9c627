// SPDX-License-Identifier: BSD-3-Clause
// The console's server: Beast HTTP + WebSocket sessions on one io_context thread. Every Store
// call happens on that thread (the Store is not thread-safe), synchronously inside a handler, so
// a robot message is stored, or refused, before its ack or error is queued.
#include "adit/console/server.hpp"

#include "server_impl.hpp"

namespace adit::console {

void logLine(const std::string& line) { std::fprintf(stderr, "adit serve: %s\n", line.c_str()); }

Json errorJson(const std::string& reason, std::optional<std::int64_t> seq) {
  Json j = {{"type", "error"}, {"reason", reason}};
  if (seq) j["seq"] = *seq;
  return j;
}

Json pointJson(const map::Vec3& p) { return Json::array({p.x(), p.y(), p.z()}); }

// Strict non-negative integer (no sign, no spaces, no trailing text, fits int64).
std::optional<std::int64_t> parseCount(const std::string& s) {
  if (s.empty() || s.size() > 18) return std::nullopt;
  for (char c : s)
    if (c < '0' || c > '9') return std::nullopt;
  return std::stoll(s);
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
  if (!(alarm_clearance_m >= 0.0 && alarm_clearance_m <= kMaxRobotRadius))
    return invalidArgument("--alarm-clearance must be in [0, 10] m");
  if (!(alarm_stale_min_s > 0.0 && alarm_stale_min_s <= kMaxTelemetryPeriod))
    return invalidArgument("--alarm-stale-min must be in (0, 60] s");
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
  d.startAlarmTimer();
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
    d.alarm_timer.cancel();
    d.ioc.stop();
  });
}

}  // namespace adit::console
