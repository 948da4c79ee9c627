// SPDX-License-Identifier: BSD-3-Clause
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>

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
  }
  return {};
}

Status checkRobot(const RobotRecord& r, const std::string& where) {
  if (r.robot.empty()) return refuse(where, "robot record with an empty robot id");
  if (!std::isfinite(r.radius)) return refuse(where, "robot '" + r.robot + "': radius is not finite");
  return {};
}

Status checkCommand(const Command& c, const std::string& where) {
  if (c.robot.empty()) return refuse(where, "command with an empty robot id");
  if (c.kind.empty()) return refuse(where, "command for robot '" + c.robot + "' has no kind");
  return {};
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
    const std::string path = url.substr(sqlite_prefix.size());
    if (path.empty()) return invalidArgument("database URL '" + url + "': no file path after 'sqlite:' (expected sqlite:PATH)");
    return detail::openSqlite(path);
  }
  if (url.rfind("postgresql://", 0) == 0 || url.rfind("postgres://", 0) == 0)
    return detail::openPostgres(url);
  return invalidArgument("database URL '" + detail::redactUrl(url) +
                         "': expected sqlite:PATH or postgresql://user@host:port/db");
}

}  // namespace adit::console
