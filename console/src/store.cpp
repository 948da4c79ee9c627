// SPDX-License-Identifier: BSD-3-Clause
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <initializer_list>
#include <limits>
#include <utility>

#include "store_internal.hpp"

namespace adit::console {

namespace detail {

const std::vector<Migration>& migrations() {
  // PostgreSQL's REAL is single precision: the poses need DOUBLE PRECISION there.
  static const std::vector<Migration> kMigrations = {
      {1,
       {"CREATE TABLE robots(robot TEXT PRIMARY KEY, map_hash TEXT, radius REAL, first_seen TEXT,"
        " last_seen TEXT)",
        "CREATE TABLE messages(robot TEXT NOT NULL, seq INTEGER NOT NULL, type TEXT NOT NULL, t REAL,"
        " received_at TEXT, body TEXT NOT NULL, PRIMARY KEY (robot, seq))",
        "CREATE TABLE telemetry(robot TEXT NOT NULL, seq INTEGER NOT NULL, t REAL, x REAL, y REAL,"
        " z REAL, vx REAL, vy REAL, vz REAL, status TEXT, PRIMARY KEY (robot, seq))",
        "CREATE TABLE commands(command_id INTEGER PRIMARY KEY, robot TEXT NOT NULL, operator TEXT,"
        " issued_at TEXT, kind TEXT NOT NULL, body TEXT, status TEXT NOT NULL, reason TEXT,"
        " updated_at TEXT)",
        "CREATE INDEX commands_by_robot_status ON commands(robot, status)"},
       {"CREATE TABLE robots(robot TEXT PRIMARY KEY, map_hash TEXT, radius DOUBLE PRECISION,"
        " first_seen TEXT, last_seen TEXT)",
        "CREATE TABLE messages(robot TEXT NOT NULL, seq BIGINT NOT NULL, type TEXT NOT NULL,"
        " t DOUBLE PRECISION, received_at TEXT, body TEXT NOT NULL, PRIMARY KEY (robot, seq))",
        "CREATE TABLE telemetry(robot TEXT NOT NULL, seq BIGINT NOT NULL, t DOUBLE PRECISION,"
        " x DOUBLE PRECISION, y DOUBLE PRECISION, z DOUBLE PRECISION, vx DOUBLE PRECISION,"
        " vy DOUBLE PRECISION, vz DOUBLE PRECISION, status TEXT, PRIMARY KEY (robot, seq))",
        "CREATE TABLE commands(command_id BIGSERIAL PRIMARY KEY, robot TEXT NOT NULL, operator TEXT,"
        " issued_at TEXT, kind TEXT NOT NULL, body TEXT, status TEXT NOT NULL, reason TEXT,"
        " updated_at TEXT)",
        "CREATE INDEX commands_by_robot_status ON commands(robot, status)"}},
      // Alarms: raised by the centre, acknowledged by an operator (who and when), cleared when
      // the condition ends. '' rather than NULL for "not yet", so both backends read alike.
      {2,
       {"CREATE TABLE alarms(alarm_id INTEGER PRIMARY KEY, robot TEXT NOT NULL, kind TEXT NOT NULL,"
        " severity TEXT NOT NULL, message TEXT NOT NULL, raised_at TEXT NOT NULL,"
        " cleared_at TEXT NOT NULL DEFAULT '', acked_at TEXT NOT NULL DEFAULT '',"
        " acked_by TEXT NOT NULL DEFAULT '')",
        "CREATE INDEX alarms_by_robot ON alarms(robot, alarm_id)"},
       {"CREATE TABLE alarms(alarm_id BIGSERIAL PRIMARY KEY, robot TEXT NOT NULL, kind TEXT NOT NULL,"
        " severity TEXT NOT NULL, message TEXT NOT NULL, raised_at TEXT NOT NULL,"
        " cleared_at TEXT NOT NULL DEFAULT '', acked_at TEXT NOT NULL DEFAULT '',"
        " acked_by TEXT NOT NULL DEFAULT '')",
        "CREATE INDEX alarms_by_robot ON alarms(robot, alarm_id)"}},
  };
  return kMigrations;
}

Status applyMigrations(MigrationTarget& db, const std::string& where) {
  const std::string create =
      "CREATE TABLE IF NOT EXISTS schema_migrations(version INTEGER PRIMARY KEY, applied_at TEXT)";
  for (;;) {
    ADIT_RETURN_IF_ERROR(db.beginExclusive());
    Status s = db.exec(create);
    StatusOr<int> version = s.ok() ? db.currentVersion() : StatusOr<int>(s);
    if (!version.ok()) {
      db.rollback();
      return version.status();
    }
    if (*version > kSchemaVersion) {
      db.rollback();
      return failedPrecondition(where + ": the database has schema version " +
                                std::to_string(*version) + ", newer than this build's " +
                                std::to_string(kSchemaVersion) + "; use a newer adit");
    }
    if (*version == kSchemaVersion) return db.commit();
    const Migration& m = migrations()[static_cast<std::size_t>(*version)];
    ADIT_DEMAND(m.version == *version + 1);
    for (const std::string& sql : db.isPostgres() ? m.postgres : m.sqlite) {
      s = db.exec(sql);
      if (!s.ok()) break;
    }
    if (s.ok())
      s = db.exec("INSERT INTO schema_migrations(version, applied_at) VALUES (" +
                  std::to_string(m.version) + ", '" + nowUtc() + "')");
    if (s.ok()) s = db.commit();
    if (!s.ok()) {
      db.rollback();
      return Status(s.code(), "migration to schema version " + std::to_string(m.version) +
                                  " failed, nothing of it applied: " + s.message());
    }
  }
}

std::string redactUrl(const std::string& url) {
  std::string out = url;
  const std::size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const std::size_t host_start = scheme + 3;
    const std::size_t at = out.find('@', host_start);
    const std::size_t slash = out.find('/', host_start);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const std::size_t colon = out.find(':', host_start);
      if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
    }
  }
  // A password passed as a query parameter (?password=...) or a keyword (password=...).
  for (std::size_t p = out.find("password="); p != std::string::npos;
       p = out.find("password=", p + 1)) {
    const std::size_t start = p + 9;
    std::size_t end = out.find_first_of("& ", start);
    if (end == std::string::npos) end = out.size();
    out.replace(start, end - start, "***");
  }
  return out;
}

std::string nowUtc() {
  using namespace std::chrono;
  const auto now = system_clock::now();
  const std::time_t secs = system_clock::to_time_t(now);
  const auto ms = duration_cast<milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>(ms));
  return out;
}

namespace {
Status refuse(const std::string& where, const std::string& what) {
  return invalidArgument(where + ": " + what + "; nothing stored");
}

/// Why PostgreSQL's TEXT could not hold `s` (a NUL byte, invalid UTF-8: RFC 3629, no overlong
/// forms, no surrogates), "" when it can. Checked for both backends, so that a message SQLite
/// would take and PostgreSQL refuse is refused by both alike.
std::string textProblem(const std::string& s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const std::size_t n = s.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned c = p[i];
    if (c == 0) return "contains a NUL byte at offset " + std::to_string(i);
    std::size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
    if (c < 0x80) len = 1;
    else if (c >= 0xC2 && c <= 0xDF) len = 2;
    else if (c == 0xE0) len = 3, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEF) len = 3, hi = c == 0xED ? 0x9F : 0xBF;
    else if (c == 0xF0) len = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) len = 4;
    else if (c == 0xF4) len = 4, hi = 0x8F;
    bool ok = len > 0 && i + len <= n;
    for (std::size_t k = 1; ok && k < len; ++k)
      ok = k == 1 ? (p[i + 1] >= lo && p[i + 1] <= hi) : (p[i + k] >= 0x80 && p[i + k] <= 0xBF);
    if (!ok) return "is not valid UTF-8 at offset " + std::to_string(i);
    i += len;
  }
  return "";
}

/// The first field of `fields` ({name, value}) that is no valid text, as a refusal.
Status checkTexts(std::initializer_list<std::pair<const char*, const std::string*>> fields,
                  const std::string& where, const std::string& who) {
  for (const auto& [name, value] : fields) {
    const std::string problem = textProblem(*value);
    if (!problem.empty()) return refuse(where, who + ": " + name + " " + problem);
  }
  return {};
}
}  // namespace

std::string messageName(const RobotMessage& m) {
  return "message (robot '" + m.robot + "', seq " + std::to_string(m.seq) + ")";
}

std::string batchName(const RobotMessage* messages, std::size_t count) {
  if (count == 1) return messageName(messages[0]);
  std::string name = "batch of " + std::to_string(count) + " messages";
  if (count > 0) name += " (first: robot '" + messages[0].robot + "', seq " + std::to_string(messages[0].seq) + ")";
  return name;
}

Status checkMessage(const RobotMessage& m, const std::string& where) {
  const std::string who = messageName(m);
  if (m.robot.empty()) return refuse(where, who + " has an empty robot id");
  if (m.seq < 1) return refuse(where, who + ": seq must be >= 1");
  if (m.type.empty()) return refuse(where, who + " has no type");
  if (!std::isfinite(m.t)) return refuse(where, who + ": t is not finite");
  if (m.type == "telemetry") {
    if (!m.pose) return refuse(where, who + ": a telemetry message needs its pose row");
    const RobotMessage::Pose& p = *m.pose;
    for (double v : {p.x, p.y, p.z, p.vx, p.vy, p.vz})
      if (!std::isfinite(v)) return refuse(where, who + ": a pose or velocity component is not finite");
    ADIT_RETURN_IF_ERROR(checkTexts({{"status", &p.status}}, where, who));
  }
  return checkTexts({{"robot", &m.robot}, {"type", &m.type}, {"received_at", &m.received_at}, {"body", &m.body}},
                    where, who);
}

Status checkRobot(const RobotRecord& r, const std::string& where) {
  if (r.robot.empty()) return refuse(where, "robot record with an empty robot id");
  if (!std::isfinite(r.radius)) return refuse(where, "robot '" + r.robot + "': radius is not finite");
  return checkTexts({{"robot", &r.robot}, {"map_hash", &r.map_hash}, {"first_seen", &r.first_seen},
                     {"last_seen", &r.last_seen}},
                    where, "robot record");
}

Status checkCommand(const Command& c, const std::string& where) {
  if (c.robot.empty()) return refuse(where, "command with an empty robot id");
  if (c.kind.empty()) return refuse(where, "command for robot '" + c.robot + "' has no kind");
  return checkTexts({{"robot", &c.robot}, {"operator", &c.operator_name}, {"issued_at", &c.issued_at},
                     {"kind", &c.kind}, {"body", &c.body}},
                    where, "command");
}

Status checkCommandUpdate(std::int64_t id, const std::string& reason, const std::string& updated_at,
                          const std::string& where) {
  return checkTexts({{"reason", &reason}, {"updated_at", &updated_at}}, where,
                    "update of command " + std::to_string(id));
}

Status checkAlarm(const Alarm& a, const std::string& where) {
  if (a.robot.empty()) return refuse(where, "alarm with an empty robot id");
  if (a.kind.empty()) return refuse(where, "alarm for robot '" + a.robot + "' has no kind");
  if (a.severity.empty()) return refuse(where, "alarm for robot '" + a.robot + "' has no severity");
  return checkTexts({{"robot", &a.robot}, {"kind", &a.kind}, {"severity", &a.severity}, {"message", &a.message},
                     {"raised_at", &a.raised_at}},
                    where, "alarm");
}

Status checkAlarmUpdate(std::int64_t id, std::initializer_list<const std::string*> texts, const std::string& where) {
  for (const std::string* t : texts)
    ADIT_RETURN_IF_ERROR(checkTexts({{"text", t}}, where, "update of alarm " + std::to_string(id)));
  return {};
}

Status alreadyAcknowledged(const Alarm& a, const std::string&) {
  // Without the database's URL: the operator who acknowledged second reads this.
  return failedPrecondition("alarm " + std::to_string(a.alarm_id) + " was acknowledged by " + a.acked_by +
                            " at " + a.acked_at);
}

bool commandStatusAdvances(CommandStatus from, CommandStatus to) {
  auto rank = [](CommandStatus s) {
    switch (s) {
      case CommandStatus::kPending: return 0;
      case CommandStatus::kSent: return 1;
      case CommandStatus::kAccepted: return 2;
      case CommandStatus::kRefused:
      case CommandStatus::kExecuted: return 3;
    }
    return 3;
  };
  return rank(to) > rank(from);
}

long long sqlLimit(std::size_t limit) {
  constexpr auto kMax = static_cast<std::size_t>(std::numeric_limits<long long>::max());
  return static_cast<long long>(limit > kMax ? kMax : limit);
}

}  // namespace detail

StatusOr<std::unique_ptr<Store>> Store::open(const std::string& url) {
  const std::string sqlite_prefix = "sqlite:";
  if (url.rfind(sqlite_prefix, 0) == 0) {
    std::string path = url.substr(sqlite_prefix.size());
    bool synchronous_full = true;
    const std::size_t query = path.rfind('?');
    if (query != std::string::npos) {
      const std::string option = path.substr(query + 1);
      if (option == "synchronous=normal") synchronous_full = false;
      else if (option != "synchronous=full")
        return invalidArgument("database URL '" + url + "': unknown option '" + option +
                               "' (sqlite:PATH takes ?synchronous=full, the default, or ?synchronous=normal)");
      path.resize(query);
    }
    if (path.empty()) return invalidArgument("database URL '" + url + "': no file path after 'sqlite:' (expected sqlite:PATH)");
    return detail::openSqlite(path, synchronous_full);
  }
  if (url.rfind("postgresql://", 0) == 0 || url.rfind("postgres://", 0) == 0)
    return detail::openPostgres(url);
  return invalidArgument("database URL '" + detail::redactUrl(url) +
                         "': expected sqlite:PATH or postgresql://user@host:port/db");
}

}  // namespace adit::console
