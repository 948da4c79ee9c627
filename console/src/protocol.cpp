// SPDX-License-Identifier: BSD-3-Clause
#include "protocol.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "adit/console/server.hpp"

namespace adit::console::protocol {
namespace {

Status refuse(const std::string& reason) { return invalidArgument(reason); }

// JSON has no NaN literal, but 1e999 parses to infinity: every number of a message is checked,
// wherever it sits, before any field is read.
bool allFinite(const Json& j, std::string* where) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!allFinite(it.value(), where)) {
        *where = where->empty() ? it.key() : it.key() + "." + *where;
        return false;
      }
  }
  if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      if (!allFinite(j[i], where)) {
        *where = "[" + std::to_string(i) + "]" + (where->empty() ? "" : "." + *where);
        return false;
      }
  }
  return true;
}

Status requireFinite(const Json& j) {
  std::string where;
  if (!allFinite(j, &where)) return refuse("field '" + where + "' is not a finite number");
  return Status::okStatus();
}

StatusOr<std::string> stringField(const Json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) return refuse(std::string("missing field '") + key + "'");
  if (!it->is_string()) return refuse(std::string("field '") + key + "' must be a string");
  return it->get<std::string>();
}

StatusOr<double> numberField(const Json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) return refuse(std::string("missing field '") + key + "'");
  if (!it->is_number()) return refuse(std::string("field '") + key + "' must be a number");
  return it->get<double>();
}

StatusOr<map::Vec3> pointOf(const Json& v, const std::string& name) {
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    return refuse("field '" + name + "' must be [x, y, z] numbers");
  return map::Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
}

StatusOr<map::Vec3> pointField(const Json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) return refuse(std::string("missing field '") + key + "'");
  return pointOf(*it, key);
}

Status optionalPointField(const Json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return Status::okStatus();
  return pointOf(*it, key).status();
}

Status pointList(const Json& j, const char* key, bool required) {
  auto it = j.find(key);
  if (it == j.end()) return required ? refuse(std::string("missing field '") + key + "'") : Status::okStatus();
  if (!it->is_array()) return refuse(std::string("field '") + key + "' must be a list of points");
  if (it->size() > kMaxPoints)
    return refuse(std::string("field '") + key + "' has " + std::to_string(it->size()) + " points, more than " +
                  std::to_string(kMaxPoints));
  for (std::size_t i = 0; i < it->size(); ++i)
    ADIT_RETURN_IF_ERROR(pointOf((*it)[i], std::string(key) + "[" + std::to_string(i) + "]").status());
  return Status::okStatus();
}

StatusOr<std::string> robotField(const Json& j) {
  ADIT_ASSIGN_OR_RETURN(std::string robot, stringField(j, "robot"));
  if (!validRobotId(robot)) return refuse(kBadRobotId);
  return robot;
}

bool oneOf(const std::string& s, std::initializer_list<const char*> values) {
  for (const char* v : values)
    if (s == v) return true;
  return false;
}

Status checkTelemetry(const Json& j, RobotMessage* m) {
  ADIT_ASSIGN_OR_RETURN(map::Vec3 pose, pointField(j, "pose"));
  ADIT_ASSIGN_OR_RETURN(map::Vec3 vel, pointField(j, "velocity"));
  ADIT_ASSIGN_OR_RETURN(std::string status, stringField(j, "status"));
  if (!oneOf(status, {"following", "yielding", "detouring", "stuck", "replanning", "no_route", "paused", "manual",
                      "arrived", "collision"}))
    return refuse("unknown status '" + status + "'");
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "goal"));
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "subgoal"));
  if (j.contains("min_clearance") && !j["min_clearance"].is_number() && !j["min_clearance"].is_null())
    return refuse("field 'min_clearance' must be a number");
  m->pose = RobotMessage::Pose{pose.x(), pose.y(), pose.z(), vel.x(), vel.y(), vel.z(), status};
  return Status::okStatus();
}

Status checkPlan(const Json& j) {
  ADIT_RETURN_IF_ERROR(stringField(j, "reason").status());
  ADIT_RETURN_IF_ERROR(pointList(j, "path", true));
  if (j.contains("labels")) {
    const Json& labels = j["labels"];
    if (!labels.is_array() || labels.size() > kMaxPoints) return refuse("field 'labels' must be a list of strings");
    for (const Json& l : labels)
      if (!l.is_string()) return refuse("field 'labels' must be a list of strings");
  }
  return Status::okStatus();
}

Status checkObstacles(const Json& j) {
  ADIT_RETURN_IF_ERROR(pointList(j, "rock", false));
  auto it = j.find("tracks");
  if (it == j.end()) return Status::okStatus();
  if (!it->is_array() || it->size() > kMaxPoints) return refuse("field 'tracks' must be a list of tracks");
  for (const Json& track : *it) {
    if (!track.is_object()) return refuse("field 'tracks' must be a list of objects");
    ADIT_RETURN_IF_ERROR(pointField(track, "position").status());
    ADIT_RETURN_IF_ERROR(optionalPointField(track, "velocity"));
    if (track.contains("radius") && !track["radius"].is_number()) return refuse("track 'radius' must be a number");
  }
  return Status::okStatus();
}

Status checkEvent(const Json& j) {
  ADIT_RETURN_IF_ERROR(stringField(j, "kind").status());
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "center"));
  if (j.contains("radius") && !j["radius"].is_number()) return refuse("field 'radius' must be a number");
  return Status::okStatus();
}

Status checkCommandResult(const Json& j) {
  auto id = j.find("command_id");
  if (id == j.end()) return refuse("missing field 'command_id'");
  if (!id->is_number_integer() || id->get<std::int64_t>() < 1)
    return refuse("field 'command_id' must be a positive integer");
  ADIT_ASSIGN_OR_RETURN(std::string result, stringField(j, "result"));
  if (!oneOf(result, {"accepted", "refused", "executed"})) return refuse("unknown result '" + result + "'");
  if (j.contains("reason") && !j["reason"].is_string()) return refuse("field 'reason' must be a string");
  return Status::okStatus();
}

std::string pointText(const map::Vec3& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%.6g, %.6g, %.6g]", p.x(), p.y(), p.z());
  return buf;
}

// The point at `v` inside `box`.
Status pointWithin(const Json& v, const std::string& name, const map::Aabb& box) {
  ADIT_ASSIGN_OR_RETURN(const map::Vec3 p, pointOf(v, name));
  if (box.contains(p)) return Status::okStatus();
  return refuse("field '" + name + "' " + pointText(p) + " is outside the map (bounds " + pointText(box.min) + " to " +
                pointText(box.max) + ", " + std::to_string(int(kMapBoundsMargin)) + " m margin included)");
}

Status optionalPointWithin(const Json& j, const char* key, const map::Aabb& box) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return Status::okStatus();
  return pointWithin(*it, key, box);
}

Status listWithin(const Json& j, const char* key, const map::Aabb& box) {
  auto it = j.find(key);
  if (it == j.end()) return Status::okStatus();
  for (std::size_t i = 0; i < it->size(); ++i)
    ADIT_RETURN_IF_ERROR(pointWithin((*it)[i], std::string(key) + "[" + std::to_string(i) + "]", box));
  return Status::okStatus();
}

Status speedAtMost(const Json& j, const char* key, const std::string& name) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return Status::okStatus();
  ADIT_ASSIGN_OR_RETURN(const map::Vec3 v, pointOf(*it, name));
  if (v.norm() <= kMaxReportedSpeed) return Status::okStatus();
  return refuse("field '" + name + "' " + pointText(v) + " is faster than " + std::to_string(int(kMaxReportedSpeed)) +
                " m/s");
}

Status radiusWithin(const Json& j, const std::string& name) {
  auto it = j.find("radius");
  if (it == j.end()) return Status::okStatus();
  const double r = it->get<double>();
  if (r >= 0.0 && r <= kMaxReportedRadius) return Status::okStatus();
  return refuse("field '" + name + "' must be in [0, " + std::to_string(int(kMaxReportedRadius)) + "] m");
}

}  // namespace

Status checkSize(const std::string& type, std::size_t bytes) {
  if ((type == "telemetry" || type == "event" || type == "command_result") && bytes > kMaxSmallMessageBytes)
    return refuse("a " + type + " message of " + std::to_string(bytes) + " bytes is over the " +
                  std::to_string(kMaxSmallMessageBytes) + " bytes allowed (only plans and obstacles carry lists)");
  return Status::okStatus();
}

Status checkWithin(const Json& j, const map::Aabb& box) {
  const std::string type = j.value("type", "");
  if (type == "telemetry") {
    ADIT_RETURN_IF_ERROR(pointWithin(j["pose"], "pose", box));
    ADIT_RETURN_IF_ERROR(speedAtMost(j, "velocity", "velocity"));
    ADIT_RETURN_IF_ERROR(optionalPointWithin(j, "goal", box));
    ADIT_RETURN_IF_ERROR(optionalPointWithin(j, "subgoal", box));
  } else if (type == "plan") {
    ADIT_RETURN_IF_ERROR(listWithin(j, "path", box));
  } else if (type == "obstacles") {
    ADIT_RETURN_IF_ERROR(listWithin(j, "rock", box));
    if (auto tracks = j.find("tracks"); tracks != j.end())
      for (std::size_t i = 0; i < tracks->size(); ++i) {
        const Json& track = (*tracks)[i];
        const std::string name = "tracks[" + std::to_string(i) + "]";
        ADIT_RETURN_IF_ERROR(pointWithin(track["position"], name + ".position", box));
        ADIT_RETURN_IF_ERROR(speedAtMost(track, "velocity", name + ".velocity"));
        ADIT_RETURN_IF_ERROR(radiusWithin(track, name + ".radius"));
      }
  } else if (type == "event") {
    ADIT_RETURN_IF_ERROR(optionalPointWithin(j, "center", box));
    ADIT_RETURN_IF_ERROR(radiusWithin(j, "radius"));
  }
  return Status::okStatus();
}

bool validRobotId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-')) return false;
  return true;
}

StatusOr<Json> parseObject(const std::string& text) {
  // nlohmann refuses 1e999 as "number overflow" (out_of_range), which is valid JSON with a
  // non-finite number: an error like NaN, not a broken stream. Caught here, nothing escapes.
  Json j;
  try {
    j = Json::parse(text);
  } catch (const nlohmann::json::out_of_range&) {
    return refuse("a number is not finite (overflows a double)");
  } catch (const nlohmann::json::exception&) {
    return refuse(kMalformedJson);
  }
  if (!j.is_object()) return refuse("a message must be a JSON object");
  return j;
}

StatusOr<Hello> parseHello(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  Hello h;
  ADIT_ASSIGN_OR_RETURN(h.robot, robotField(j));
  ADIT_ASSIGN_OR_RETURN(h.map_hash, stringField(j, "map_hash"));
  if (j.contains("map")) {
    if (!j["map"].is_string()) return refuse("field 'map' must be a string");
    h.map = j["map"].get<std::string>();
  }
  ADIT_ASSIGN_OR_RETURN(h.radius, numberField(j, "radius"));
  if (!(h.radius > 0.0) || h.radius > kMaxRobotRadius)
    return refuse("field 'radius' must be in (0, " + std::to_string(int(kMaxRobotRadius)) + "] m");
  return h;
}

StatusOr<RobotMessage> parseRobotMessage(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  RobotMessage m;
  ADIT_ASSIGN_OR_RETURN(m.type, stringField(j, "type"));
  ADIT_ASSIGN_OR_RETURN(m.robot, robotField(j));
  auto seq = j.find("seq");
  if (seq == j.end()) return refuse("missing field 'seq'");
  if (!seq->is_number_integer() || seq->get<std::int64_t>() < 1 || seq->get<std::int64_t>() > kMaxSeq)
    return refuse("field 'seq' must be an integer in 1..9007199254740991 (2^53 - 1)");
  m.seq = seq->get<std::int64_t>();
  ADIT_ASSIGN_OR_RETURN(m.t, numberField(j, "t"));
  if (m.type == "telemetry") {
    ADIT_RETURN_IF_ERROR(checkTelemetry(j, &m));
  } else if (m.type == "plan") {
    ADIT_RETURN_IF_ERROR(checkPlan(j));
  } else if (m.type == "obstacles") {
    ADIT_RETURN_IF_ERROR(checkObstacles(j));
  } else if (m.type == "event") {
    ADIT_RETURN_IF_ERROR(checkEvent(j));
  } else if (m.type == "command_result") {
    ADIT_RETURN_IF_ERROR(checkCommandResult(j));
  } else {
    return refuse("unknown message type '" + m.type + "'");
  }
  return m;
}

CommandResult commandResultOf(const Json& j) {
  CommandResult r;
  r.command_id = j["command_id"].get<std::int64_t>();
  r.status = *parseCommandStatus(j["result"].get<std::string>());
  r.reason = j.value("reason", std::string());
  return r;
}

StatusOr<CommandRequest> parseCommandRequest(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  CommandRequest c;
  ADIT_ASSIGN_OR_RETURN(c.robot, robotField(j));
  ADIT_ASSIGN_OR_RETURN(static_cast<CommandArgs&>(c), parseCommandArgs(j));
  return c;
}

StatusOr<CommandArgs> parseCommandArgs(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  CommandArgs c;
  ADIT_ASSIGN_OR_RETURN(c.kind, stringField(j, "kind"));
  if (c.kind == "goal") {
    ADIT_ASSIGN_OR_RETURN(map::Vec3 goal, pointField(j, "goal"));
    c.goal = goal;
  } else if (c.kind == "block" || c.kind == "reopen") {
    ADIT_ASSIGN_OR_RETURN(c.roadway, stringField(j, "roadway"));
  } else if (c.kind == "manual") {
    ADIT_ASSIGN_OR_RETURN(map::Vec3 v, pointField(j, "velocity"));
    c.velocity = v;
  } else if (!oneOf(c.kind, {"pause", "resume", "release"})) {
    return refuse("unknown command kind '" + c.kind + "'");
  }
  return c;
}

Json commandMessage(const Command& c) {
  Json j = Json::parse(c.body, nullptr, false);
  if (!j.is_object()) j = Json::object();
  j["type"] = "command";
  j["command_id"] = c.command_id;
  j["kind"] = c.kind;
  j["operator"] = c.operator_name;
  j.erase("robot");
  return j;
}

Json commandState(const Command& c) {
  Json j = commandMessage(c);
  j["robot"] = c.robot;
  j["status"] = commandStatusName(c.status);
  j["reason"] = c.reason;
  j["issued_at"] = c.issued_at;
  j["updated_at"] = c.updated_at;
  return j;
}

std::string isoNow() {
  using namespace std::chrono;
  const auto now = system_clock::now();
  const std::time_t secs = system_clock::to_time_t(now);
  const long ms = static_cast<long>(duration_cast<milliseconds>(now.time_since_epoch()).count() % 1000);
  std::tm utc{};
  gmtime_r(&secs, &utc);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &utc);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03ldZ", buf, ms);
  return out;
}

}  // namespace adit::console::protocol
