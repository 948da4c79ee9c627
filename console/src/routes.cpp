// SPDX-License-Identifier: BSD-3-Clause
// The console's HTTP routes: the page and its assets, the REST API (console/doc/protocol.md),
// who may open a WebSocket, and the operator's commands.
#include "web_assets.hpp"
#include "ws_session.hpp"

namespace adit::console {
namespace {

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

}  // namespace

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
                  {"roadways", roadway_list},
                  {"alarms", {{"clearance", options.alarm_clearance_m}, {"stale_min", options.alarm_stale_min_s}}}}
                 .dump();
  ADIT_ASSIGN_OR_RETURN(RoadwayMesh mesh, buildRoadwayMesh(m, options.mesh_cell));
  mesh_json = Json{{"cell", mesh.cell}, {"positions", mesh.positions}, {"normals", mesh.normals}, {"indices", mesh.indices}}
                  .dump();
  warmCache();
  return Status::okStatus();
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
  // The e-stop is the highest priority: never held back by the pending limit, and while it is in
  // force nothing that would move the robot is sent (the robot refuses it too).
  const bool estop_kind = cmd->kind == "estop" || cmd->kind == "estop_release";
  const std::optional<Command>& estop = cache[cmd->robot].estop;
  if (cmd->kind == "estop_release" && !estop)
    return refusal(req, http::status::conflict, "robot '" + cmd->robot + "' is not e-stopped");
  if (estop && (cmd->kind == "resume" || cmd->kind == "goal" || cmd->kind == "manual" || cmd->kind == "release"))
    return refusal(req, http::status::conflict,
                   "robot '" + cmd->robot + "' is e-stopped (command " + std::to_string(estop->command_id) + " by " +
                       estop->operator_name + "): release the e-stop first");
  if (!estop_kind) {
    StatusOr<std::vector<Command>> pending = store->unansweredCommands(cmd->robot);
    if (!pending.ok()) return refusal(req, http::status::internal_server_error, "database: " + pending.status().message());
    if (pending->size() >= kMaxPendingCommands)
      return refusal(req, http::status::too_many_requests,
                     std::to_string(pending->size()) + " commands of " + cmd->robot + " are still unanswered");
  }
  StatusOr<std::int64_t> id = issueCommand(cmd->robot, cmd->kind, args.dump());
  if (!id.ok()) return refusal(req, http::status::internal_server_error, "database: " + id.status().message());
  return jsonResponse(req, http::status::accepted, Json{{"command_id", *id}, {"status", "pending"}}.dump());
}

StatusOr<std::int64_t> Server::Impl::issueCommand(const std::string& robot, const std::string& kind,
                                                  const std::string& args) {
  Command c;
  c.robot = robot;
  c.operator_name = options.operator_name;
  c.issued_at = c.updated_at = protocol::isoNow();
  c.kind = kind;
  c.body = args;
  ADIT_ASSIGN_OR_RETURN(c.command_id, store->addCommand(c));
  broadcast(protocol::commandState(c), false);
  noteEstop(c);
  deliver(c);
  return c.command_id;
}

// Every robot the centre knows, connected or not: one that is offline gets its e-stop first
// thing at its next hello.
Response Server::Impl::handleEstopAll(const Request& req) {
  if (std::optional<Response> refused = requireOperator(req)) return *refused;
  StatusOr<std::vector<RobotRecord>> robots = store->robots();
  if (!robots.ok()) return refusal(req, http::status::internal_server_error, "database: " + robots.status().message());
  Json issued = Json::array();
  for (const RobotRecord& r : *robots) {
    StatusOr<std::int64_t> id = issueCommand(r.robot, "estop", "{}");
    if (!id.ok()) return refusal(req, http::status::internal_server_error, "database: " + id.status().message());
    issued.push_back({{"robot", r.robot}, {"command_id", *id}, {"status", "pending"}});
  }
  return jsonResponse(req, http::status::accepted, Json{{"commands", issued}}.dump());
}

Response Server::Impl::handleAlarmAck(const Request& req) {
  if (std::optional<Response> refused = requireOperator(req)) return *refused;
  StatusOr<Json> body = protocol::parseObject(req.body());
  if (!body.ok()) return refusal(req, http::status::bad_request, body.status().message());
  const auto id = body->find("alarm_id");
  if (id == body->end() || !id->is_number_integer() || id->get<std::int64_t>() < 1)
    return refusal(req, http::status::bad_request, "field 'alarm_id' must be a positive integer");
  StatusOr<Alarm> acked = store->acknowledgeAlarm(id->get<std::int64_t>(), options.operator_name, protocol::isoNow());
  if (!acked.ok()) {
    const StatusCode code = acked.status().code();
    const http::status status = code == StatusCode::kNotFound             ? http::status::not_found
                                : code == StatusCode::kFailedPrecondition ? http::status::conflict
                                                                          : http::status::internal_server_error;
    return refusal(req, status, acked.status().message());
  }
  if (acked->open()) open_alarms[acked->alarm_id] = *acked;
  else open_alarms.erase(acked->alarm_id);
  logLine("alarm " + std::to_string(acked->alarm_id) + " acknowledged by " + acked->acked_by);
  const Json j = alarmJson(*acked);
  broadcast(j, false);
  return jsonResponse(req, http::status::ok, j.dump());
}

Response Server::Impl::handleAlarmsGet(const Request& req, const std::map<std::string, std::string>& query) {
  const std::string robot = query.count("robot") ? query.at("robot") : "";
  if (!robot.empty() && !protocol::validRobotId(robot)) return refusal(req, http::status::bad_request, protocol::kBadRobotId);
  const std::string open = query.count("open") ? query.at("open") : "0";
  if (open != "0" && open != "1") return refusal(req, http::status::bad_request, "open must be 0 or 1");
  auto list = store->alarms(robot, open == "1", 10000);
  if (!list.ok()) return refusal(req, http::status::internal_server_error, "database: " + list.status().message());
  Json out = Json::array();
  for (const Alarm& a : *list) out.push_back(alarmJson(a));
  return jsonResponse(req, http::status::ok, out.dump());
}

Response Server::Impl::handle(const Request& req) {
  const std::string target(req.target());
  const auto q = target.find('?');
  const std::string path = target.substr(0, q);
  const auto query = parseQuery(q == std::string::npos ? "" : target.substr(q + 1));
  const bool get = req.method() == http::verb::get || req.method() == http::verb::head;
  if (req.method() == http::verb::post) {
    if (path == "/api/commands") return handleCommandPost(req);
    if (path == "/api/estop-all") return handleEstopAll(req);
    if (path == "/api/alarms/ack") return handleAlarmAck(req);
  }
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
  if (path == "/api/alarms") return handleAlarmsGet(req, query);
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

}  // namespace adit::console
