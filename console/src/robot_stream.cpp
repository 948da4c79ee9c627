// SPDX-License-Identifier: BSD-3-Clause
// The console's robot state machine: a robot's hello, each message it sends checked against the
// protocol, its quotas and the map, then queued for the writer; commands delivered to robots;
// what viewers are sent.
#include "ws_session.hpp"

namespace adit::console {

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
    // While e-stopped the centre refuses every command but estop and estop_release, so the
    // robot's e-stop, if in force, is among its last commands.
    if (auto list = store->commands(r.robot, 1000); list.ok())
      for (const Command& k : *list) {
        if (k.kind == "estop") c.estop = k;
        if (k.kind == "estop_release" && k.status == CommandStatus::kExecuted) c.estop.reset();
      }
  }
  warmAlarms();
}

Json Server::Impl::estopJson(const std::optional<Command>& estop) {
  if (!estop) return nullptr;
  return Json{{"command_id", estop->command_id},
              {"status", commandStatusName(estop->status)},
              {"engaged", estop->status == CommandStatus::kExecuted},
              {"operator", estop->operator_name},
              {"issued_at", estop->issued_at},
              {"updated_at", estop->updated_at},
              {"reason", estop->reason}};
}

// An e-stop is in force from its issue until an estop_release is executed by the robot; every
// change is pushed to the viewers as {"type": "estop"} (the page shows it until released).
void Server::Impl::noteEstop(const Command& c) {
  RobotCache& rc = cache[c.robot];
  if (c.kind == "estop") {
    if (rc.estop && rc.estop->command_id > c.command_id) return;  // an older one's late answer
    rc.estop = c;
  } else if (c.kind == "estop_release" && c.status == CommandStatus::kExecuted) {
    if (!rc.estop || rc.estop->command_id > c.command_id) return;
    rc.estop.reset();
  } else {
    return;
  }
  broadcast(Json{{"type", "estop"}, {"robot", c.robot}, {"estop", estopJson(rc.estop)}}, false);
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
  noteEstop(command);
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
    endAlarm(hello->robot, "lost_link");
    // The stale clock starts again at the hello, not at the last telemetry before the drop.
    if (cache[hello->robot].telemetry_at) cache[hello->robot].telemetry_at = std::chrono::steady_clock::now();
    // An e-stop goes first: the robot stops before it reads a goal queued ahead of it.
    std::stable_partition(unanswered->begin(), unanswered->end(), [](const Command& c) { return c.kind == "estop"; });
    for (const Command& c : *unanswered) deliver(c);
    return;
  }
  if (session.robotId().empty()) {
    session.refuse("send hello first", seq);
    return;
  }
  StatusOr<protocol::RobotFrame> frame = protocol::parseRobotMessage(j);
  if (!frame.ok()) {
    session.refuse(frame.status().message(), seq);
    return;
  }
  RobotMessage* message = &frame->message;
  if (message->robot != session.robotId()) {
    session.refuse("unknown robot '" + message->robot + "' (this connection is '" + session.robotId() + "')", seq);
    return;
  }
  std::optional<Command> command;
  if (const auto* r = std::get_if<CommandResult>(&frame->body)) {
    StatusOr<std::optional<Command>> c = store->command(r->command_id);
    if (c.ok() && (!*c || (*c)->robot != message->robot)) {
      session.refuse("unknown command_id " + std::to_string(r->command_id) + " for robot " + message->robot, seq);
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
  if (Status within = protocol::checkWithin(frame->body, bounds); !within.ok()) {
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
  if (const auto* tm = std::get_if<Telemetry>(&frame->body)) onTelemetryArrived(message->robot, *tm);
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
  p.body = std::move(frame->body);
  p.json = j;
  p.command = std::move(command);
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    queue.push_back(std::move(p));
  }
  queue_cv.notify_one();
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
                   {"tracks", c.tracks.is_null() ? Json::array() : c.tracks},
                   {"estop", estopJson(c.estop)}});
  }
  return out;
}

void Server::Impl::onViewerOpen(const std::shared_ptr<WsSession>& session) {
  Json commands = Json::array();
  if (auto list = store->commands("", 100); list.ok())
    for (const Command& c : *list) commands.push_back(protocol::commandState(c));
  session->send(
      Json{{"type", "snapshot"}, {"robots", robotsJson()}, {"commands", commands}, {"alarms", openAlarmsJson()}});
  viewers[session.get()] = session;
}

}  // namespace adit::console
