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

// An absent or null field leaves `out` empty.
Status optionalPointField(const Json& j, const char* key, std::optional<map::Vec3>* out) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return Status::okStatus();
  ADIT_ASSIGN_OR_RETURN(*out, pointOf(*it, key));
  return Status::okStatus();
}

Status optionalNumberField(const Json& j, const char* key, const std::string& name, std::optional<double>* out) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return Status::okStatus();
  if (!it->is_number()) return refuse("field '" + name + "' must be a number");
  *out = it->get<double>();
  return Status::okStatus();
}

// Names, labels and kinds are words, not payloads: an attacker's megabyte "label" is refused.
constexpr std::size_t kMaxWordLength = 64;

Status wordOf(const Json& v, const std::string& name, std::string* out) {
  if (!v.is_string()) return refuse("field '" + name + "' must be a string");
  *out = v.get<std::string>();
  if (out->size() > kMaxWordLength)
    return refuse("field '" + name + "' is longer than " + std::to_string(kMaxWordLength) + " bytes (UTF-8)");
  return Status::okStatus();
}

Status wordField(const Json& j, const char* key, std::string* out) {
  auto it = j.find(key);
  if (it == j.end()) return refuse(std::string("missing field '") + key + "'");
  return wordOf(*it, key, out);
}

Status listSize(const Json& v, const char* key, const char* what) {
  if (!v.is_array()) return refuse(std::string("field '") + key + "' must be a list of " + what);
  if (v.size() > kMaxPoints)
    return refuse(std::string("field '") + key + "' has " + std::to_string(v.size()) + " " + what + ", more than " +
                  std::to_string(kMaxPoints));
  return Status::okStatus();
}

Status pointList(const Json& j, const char* key, bool required, std::vector<map::Vec3>* out) {
  auto it = j.find(key);
  if (it == j.end()) return required ? refuse(std::string("missing field '") + key + "'") : Status::okStatus();
  ADIT_RETURN_IF_ERROR(listSize(*it, key, "points"));
  out->reserve(it->size());
  for (std::size_t i = 0; i < it->size(); ++i) {
    ADIT_ASSIGN_OR_RETURN(map::Vec3 p, pointOf((*it)[i], std::string(key) + "[" + std::to_string(i) + "]"));
    out->push_back(p);
  }
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

StatusOr<Telemetry> readTelemetry(const Json& j, double t) {
  Telemetry m;
  m.t = t;
  ADIT_ASSIGN_OR_RETURN(m.pose, pointField(j, "pose"));
  ADIT_ASSIGN_OR_RETURN(m.velocity, pointField(j, "velocity"));
  ADIT_RETURN_IF_ERROR(wordField(j, "status", &m.status));
  if (!oneOf(m.status, {"following", "yielding", "detouring", "stuck", "replanning", "no_route", "paused", "manual",
                        "arrived", "collision", "estop"}))
    return refuse("unknown status '" + m.status + "'");
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "goal", &m.goal));
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "subgoal", &m.subgoal));
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "min_clearance", "min_clearance", &m.min_clearance));
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "speed", "speed", &m.speed));
  if (m.speed && *m.speed < 0.0) return refuse("field 'speed' must be >= 0");
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "period", "period", &m.period));
  if (m.period && !(*m.period > 0.0 && *m.period <= kMaxTelemetryPeriod))
    return refuse("field 'period' must be in (0, " + std::to_string(int(kMaxTelemetryPeriod)) + "] s");
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "yaw", "yaw", &m.yaw));
  if (m.yaw && std::abs(*m.yaw) > 100.0) return refuse("field 'yaw' must be within 100 rad of 0");
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "body", &m.body));
  if (m.body && !((m.body->array() > 0.0).all() && (m.body->array() <= 2.0 * kMaxRobotRadius).all()))
    return refuse("field 'body' must be [length, width, height], each in (0, " + std::to_string(int(2.0 * kMaxRobotRadius)) +
                  "] m");
  if (auto shape = j.find("body_shape"); shape != j.end() && !shape->is_null()) {
    std::string s;
    ADIT_RETURN_IF_ERROR(wordOf(*shape, "body_shape", &s));
    if (!oneOf(s, {"box", "cylinder"})) return refuse("field 'body_shape' must be 'box' or 'cylinder'");
    if (!m.body) return refuse("field 'body_shape' needs a 'body'");
    if (s == "cylinder" && m.body->x() != m.body->y())
      return refuse("field 'body' of a cylinder must be [diameter, diameter, height]");
    m.body_shape = s;
  }
  return m;
}

StatusOr<Plan> readPlan(const Json& j, double t) {
  Plan m;
  m.t = t;
  ADIT_RETURN_IF_ERROR(wordField(j, "reason", &m.reason));
  ADIT_RETURN_IF_ERROR(pointList(j, "path", true, &m.path));
  if (auto labels = j.find("labels"); labels != j.end()) {
    ADIT_RETURN_IF_ERROR(listSize(*labels, "labels", "strings"));
    m.labels.resize(labels->size());
    for (std::size_t i = 0; i < labels->size(); ++i)
      ADIT_RETURN_IF_ERROR(wordOf((*labels)[i], "labels[" + std::to_string(i) + "]", &m.labels[i]));
  }
  return m;
}

StatusOr<Obstacles> readObstacles(const Json& j, double t) {
  Obstacles m;
  m.t = t;
  ADIT_RETURN_IF_ERROR(pointList(j, "rock", false, &m.rock));
  auto tracks = j.find("tracks");
  if (tracks == j.end()) return m;
  ADIT_RETURN_IF_ERROR(listSize(*tracks, "tracks", "tracks"));
  m.tracks.resize(tracks->size());
  for (std::size_t i = 0; i < tracks->size(); ++i) {
    const Json& track = (*tracks)[i];
    const std::string name = "tracks[" + std::to_string(i) + "]";
    if (!track.is_object()) return refuse("field '" + name + "' must be an object");
    TrackReport& r = m.tracks[i];
    if (auto id = track.find("id"); id != track.end()) ADIT_RETURN_IF_ERROR(wordOf(*id, name + ".id", &r.id));
    auto position = track.find("position");
    if (position == track.end()) return refuse("missing field '" + name + ".position'");
    ADIT_ASSIGN_OR_RETURN(r.position, pointOf(*position, name + ".position"));
    if (auto v = track.find("velocity"); v != track.end() && !v->is_null()) {
      ADIT_ASSIGN_OR_RETURN(r.velocity, pointOf(*v, name + ".velocity"));
    }
    std::optional<double> radius;
    ADIT_RETURN_IF_ERROR(optionalNumberField(track, "radius", name + ".radius", &radius));
    r.radius = radius.value_or(0.0);
  }
  return m;
}

StatusOr<Event> readEvent(const Json& j, double t) {
  Event m;
  m.t = t;
  ADIT_RETURN_IF_ERROR(wordField(j, "kind", &m.kind));
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "at", "at", &m.at));
  ADIT_RETURN_IF_ERROR(optionalPointField(j, "center", &m.center));
  ADIT_RETURN_IF_ERROR(optionalNumberField(j, "radius", "radius", &m.radius));
  return m;
}

StatusOr<CommandResult> readCommandResult(const Json& j, double t) {
  CommandResult m;
  m.t = t;
  auto id = j.find("command_id");
  if (id == j.end()) return refuse("missing field 'command_id'");
  if (!id->is_number_integer() || id->get<std::int64_t>() < 1 || id->get<std::int64_t>() > kMaxSeq)
    return refuse("field 'command_id' must be an integer in 1..9007199254740991 (2^53 - 1)");
  m.command_id = id->get<std::int64_t>();
  ADIT_ASSIGN_OR_RETURN(m.result, stringField(j, "result"));
  if (!oneOf(m.result, {"accepted", "refused", "executed"})) return refuse("unknown result '" + m.result + "'");
  if (auto reason = j.find("reason"); reason != j.end()) {
    if (!reason->is_string()) return refuse("field 'reason' must be a string");
    m.reason = reason->get<std::string>();
  }
  return m;
}

std::string pointText(const map::Vec3& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%.6g, %.6g, %.6g]", p.x(), p.y(), p.z());
  return buf;
}

Status pointWithin(const map::Vec3& p, const std::string& name, const map::Aabb& box) {
  if (box.contains(p)) return Status::okStatus();
  return refuse("field '" + name + "' " + pointText(p) + " is outside the map (bounds " + pointText(box.min) + " to " +
                pointText(box.max) + ", " + std::to_string(int(kMapBoundsMargin)) + " m margin included)");
}

Status optionalPointWithin(const std::optional<map::Vec3>& p, const char* name, const map::Aabb& box) {
  return p ? pointWithin(*p, name, box) : Status::okStatus();
}

Status listWithin(const std::vector<map::Vec3>& ps, const char* key, const map::Aabb& box) {
  for (std::size_t i = 0; i < ps.size(); ++i)
    ADIT_RETURN_IF_ERROR(pointWithin(ps[i], std::string(key) + "[" + std::to_string(i) + "]", box));
  return Status::okStatus();
}

Status speedAtMost(const map::Vec3& v, const std::string& name) {
  if (v.norm() <= kMaxReportedSpeed) return Status::okStatus();
  return refuse("field '" + name + "' " + pointText(v) + " is faster than " + std::to_string(int(kMaxReportedSpeed)) +
                " m/s");
}

Status radiusWithin(double r, const std::string& name) {
  if (r >= 0.0 && r <= kMaxReportedRadius) return Status::okStatus();
  return refuse("field '" + name + "' must be in [0, " + std::to_string(int(kMaxReportedRadius)) + "] m");
}

struct WithinVisitor {
  const map::Aabb& box;
  Status operator()(const Telemetry& m) const {
    ADIT_RETURN_IF_ERROR(pointWithin(m.pose, "pose", box));
    ADIT_RETURN_IF_ERROR(speedAtMost(m.velocity, "velocity"));
    if (m.speed && *m.speed > kMaxReportedSpeed)
      return refuse("field 'speed' " + std::to_string(*m.speed) + " is faster than " +
                    std::to_string(int(kMaxReportedSpeed)) + " m/s");
    ADIT_RETURN_IF_ERROR(optionalPointWithin(m.goal, "goal", box));
    return optionalPointWithin(m.subgoal, "subgoal", box);
  }
  Status operator()(const Plan& m) const { return listWithin(m.path, "path", box); }
  Status operator()(const Obstacles& m) const {
    ADIT_RETURN_IF_ERROR(listWithin(m.rock, "rock", box));
    for (std::size_t i = 0; i < m.tracks.size(); ++i) {
      const std::string name = "tracks[" + std::to_string(i) + "]";
      ADIT_RETURN_IF_ERROR(pointWithin(m.tracks[i].position, name + ".position", box));
      ADIT_RETURN_IF_ERROR(speedAtMost(m.tracks[i].velocity, name + ".velocity"));
      ADIT_RETURN_IF_ERROR(radiusWithin(m.tracks[i].radius, name + ".radius"));
    }
    return Status::okStatus();
  }
  Status operator()(const Event& m) const {
    ADIT_RETURN_IF_ERROR(optionalPointWithin(m.center, "center", box));
    return m.radius ? radiusWithin(*m.radius, "radius") : Status::okStatus();
  }
  Status operator()(const CommandResult&) const { return Status::okStatus(); }
};

}  // namespace

Status checkSize(const std::string& type, std::size_t bytes) {
  if ((type == "telemetry" || type == "event" || type == "command_result") && bytes > kMaxSmallMessageBytes)
    return refuse("a " + type + " message of " + std::to_string(bytes) + " bytes is over the " +
                  std::to_string(kMaxSmallMessageBytes) + " bytes allowed (only plans and obstacles carry lists)");
  return Status::okStatus();
}

Status checkWithin(const Body& body, const map::Aabb& box) { return std::visit(WithinVisitor{box}, body); }

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

template <class T>
StatusOr<Body> asBody(StatusOr<T> message) {
  if (!message.ok()) return message.status();
  return Body(std::move(message).value());
}

const char* typeOf(const Body& body) {
  static constexpr const char* kNames[] = {"telemetry", "plan", "obstacles", "event", "command_result"};
  return kNames[body.index()];
}

StatusOr<Body> parseBody(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  ADIT_ASSIGN_OR_RETURN(const std::string type, stringField(j, "type"));
  ADIT_ASSIGN_OR_RETURN(const double t, numberField(j, "t"));
  if (type == "telemetry") return asBody(readTelemetry(j, t));
  if (type == "plan") return asBody(readPlan(j, t));
  if (type == "obstacles") return asBody(readObstacles(j, t));
  if (type == "event") return asBody(readEvent(j, t));
  if (type == "command_result") return asBody(readCommandResult(j, t));
  return refuse("unknown message type '" + type + "'");
}

StatusOr<RobotFrame> parseRobotMessage(const Json& j) {
  ADIT_RETURN_IF_ERROR(requireFinite(j));
  RobotFrame f;
  RobotMessage& m = f.message;
  ADIT_ASSIGN_OR_RETURN(m.type, stringField(j, "type"));
  ADIT_ASSIGN_OR_RETURN(m.robot, robotField(j));
  auto seq = j.find("seq");
  if (seq == j.end()) return refuse("missing field 'seq'");
  if (!seq->is_number_integer() || seq->get<std::int64_t>() < 1 || seq->get<std::int64_t>() > kMaxSeq)
    return refuse("field 'seq' must be an integer in 1..9007199254740991 (2^53 - 1)");
  m.seq = seq->get<std::int64_t>();
  ADIT_ASSIGN_OR_RETURN(f.body, parseBody(j));
  m.t = std::visit([](const auto& b) { return b.t; }, f.body);
  if (const auto* tm = std::get_if<Telemetry>(&f.body))
    m.pose = RobotMessage::Pose{tm->pose.x(),     tm->pose.y(),     tm->pose.z(), tm->velocity.x(),
                                tm->velocity.y(), tm->velocity.z(), tm->status};
  return f;
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
  } else if (!oneOf(c.kind, {"pause", "resume", "release", "estop", "estop_release"})) {
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
