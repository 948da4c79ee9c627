// SPDX-License-Identifier: BSD-3-Clause
// The embedded backend. Durability: WAL journal with synchronous=FULL by default, so every
// committed transaction is fsynced to the WAL before appendMessage() returns: an acknowledged
// message survives a killed process AND a power cut or OS crash. `sqlite:PATH?synchronous=normal`
// trades the power cut for speed: a commit is written to the WAL (the OS page cache) without an
// fsync, so it survives a killed process but not a power cut or OS crash, and the robot forgets
// what the centre acknowledged; the database itself stays consistent either way. WAL rather
// than a rollback journal: one fsync per commit instead of two, and readers (a second `adit`
// process, a backup) never block the writer.
#include <sqlite3.h>

#include <cmath>
#include <utility>

#include "store_internal.hpp"

namespace adit::console::detail {
namespace {

/// A prepared statement, reset after each use so it can be reused.
class Statement {
 public:
  Statement() = default;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement() { sqlite3_finalize(stmt_); }
  sqlite3_stmt** out() { return &stmt_; }
  sqlite3_stmt* get() const { return stmt_; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

/// Resets and clears a statement's bindings when a use of it ends, whichever way.
class Use {
 public:
  explicit Use(const Statement& s) : stmt_(s.get()) {}
  Use(const Use&) = delete;
  Use& operator=(const Use&) = delete;
  ~Use() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  void bind(int i, const std::string& v) { sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT); }
  void bind(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
  void bind(int i, long long v) { sqlite3_bind_int64(stmt_, i, v); }
  int step() { return sqlite3_step(stmt_); }
  std::string text(int col) const {
    const unsigned char* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }
  long long integer(int col) const { return sqlite3_column_int64(stmt_, col); }
  bool isNull(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }

 private:
  sqlite3_stmt* stmt_;
};

StatusCode codeOf(int rc) {
  switch (rc & 0xff) {
    case SQLITE_NOTADB:
    case SQLITE_CORRUPT: return StatusCode::kDataLoss;
    case SQLITE_CANTOPEN: return StatusCode::kNotFound;
    case SQLITE_CONSTRAINT:
    case SQLITE_MISMATCH:
    case SQLITE_TOOBIG: return StatusCode::kInvalidArgument;
    case SQLITE_READONLY:
    case SQLITE_PERM:
    case SQLITE_BUSY:
    case SQLITE_LOCKED: return StatusCode::kFailedPrecondition;
    default: return StatusCode::kInternal;
  }
}

class SqliteStore final : public Store, private MigrationTarget {
 public:
  SqliteStore(std::string path, bool synchronous_full)
      : path_(std::move(path)), where_("sqlite:" + path_), synchronous_full_(synchronous_full) {}
  // close_v2: the connection closes once the member statements are finalised after this body.
  ~SqliteStore() override { sqlite3_close_v2(db_); }

  Status open() {
    const int rc = sqlite3_open_v2(path_.c_str(), &db_,
                                   SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
    if (rc != SQLITE_OK) return error(rc, "cannot open the database file");
    sqlite3_extended_result_codes(db_, 1);
    // Another process (a second reader, a backup) may hold the lock briefly: wait, do not fail.
    sqlite3_busy_timeout(db_, 5000);
    // The first statement reads the header: a file that is not a database fails here.
    ADIT_RETURN_IF_ERROR(switchToWal());
    ADIT_RETURN_IF_ERROR(execChecked(synchronous_full_ ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL",
                                     "cannot set the synchronous mode"));
    ADIT_RETURN_IF_ERROR(applyMigrations(*this, where_));
    return prepareAll();
  }

  std::string backend() const override { return "sqlite"; }

  StatusOr<int> schemaVersion() override { return currentVersion(); }

  Status upsertRobot(const RobotRecord& r) override {
    ADIT_RETURN_IF_ERROR(checkRobot(r, where_));
    Use u(upsert_robot_);
    u.bind(1, r.robot);
    u.bind(2, r.map_hash);
    u.bind(3, r.radius);
    u.bind(4, r.first_seen.empty() ? r.last_seen : r.first_seen);
    u.bind(5, r.last_seen);
    const int rc = u.step();
    return rc == SQLITE_DONE ? Status() : error(rc, "cannot store robot '" + r.robot + "'");
  }

  StatusOr<std::vector<RobotRecord>> robots() override {
    std::vector<RobotRecord> out;
    Use u(robots_);
    ADIT_RETURN_IF_ERROR(readRobots(u, out, "cannot read the robots"));
    return out;
  }

  StatusOr<std::optional<RobotRecord>> robot(const std::string& robot) override {
    std::vector<RobotRecord> out;
    Use u(robot_);
    u.bind(1, robot);
    ADIT_RETURN_IF_ERROR(readRobots(u, out, "cannot read robot '" + robot + "'"));
    if (out.empty()) return std::optional<RobotRecord>();
    return std::optional<RobotRecord>(std::move(out.front()));
  }

  StatusOr<std::int64_t> lastSeq(const std::string& robot) override {
    Use u(last_seq_);
    u.bind(1, robot);
    const int rc = u.step();
    if (rc != SQLITE_ROW) return error(rc, "cannot read the last seq of robot '" + robot + "'");
    return static_cast<std::int64_t>(u.integer(0));
  }

  StatusOr<std::int64_t> storedBytes(const std::string& robot) override {
    Use u(stored_bytes_);
    u.bind(1, robot);
    const int rc = u.step();
    if (rc != SQLITE_ROW) return error(rc, "cannot read the stored bytes of robot '" + robot + "'");
    return static_cast<std::int64_t>(u.integer(0));
  }

  StatusOr<std::vector<RobotMessage>> history(const std::string& robot, std::int64_t from_seq, std::size_t limit,
                                              std::size_t max_bytes) override {
    std::vector<RobotMessage> out;
    Use u(history_);
    u.bind(1, robot);
    u.bind(2, static_cast<long long>(from_seq));
    u.bind(3, sqlLimit(limit));
    int rc;
    std::size_t bytes = 0;
    while (bytes < max_bytes && (rc = u.step()) == SQLITE_ROW) {
      out.push_back(messageFromRow(u));
      if (!u.isNull(6)) out.back().pose = poseFromRow(u, 6);
      bytes += out.back().body.size();
    }
    if (bytes >= max_bytes) return out;  // stopped early: the statement is reset by Use
    if (rc != SQLITE_DONE) return error(rc, "cannot read the history of robot '" + robot + "'");
    return out;
  }

  StatusOr<std::optional<RobotMessage>> lastOfType(const std::string& robot, const std::string& type) override {
    Use u(last_of_type_);
    u.bind(1, robot);
    u.bind(2, type);
    const int rc = u.step();
    if (rc == SQLITE_DONE) return std::optional<RobotMessage>();
    if (rc != SQLITE_ROW) return error(rc, "cannot read the last " + type + " of robot '" + robot + "'");
    return std::optional<RobotMessage>(messageFromRow(u));
  }

  StatusOr<std::int64_t> telemetryRows() override {
    Use u(telemetry_rows_);
    const int rc = u.step();
    if (rc != SQLITE_ROW) return error(rc, "cannot count the telemetry rows");
    return static_cast<std::int64_t>(u.integer(0));
  }

  StatusOr<std::int64_t> addCommand(const Command& c) override {
    ADIT_RETURN_IF_ERROR(checkCommand(c, where_));
    Use u(add_command_);
    u.bind(1, c.robot);
    u.bind(2, c.operator_name);
    u.bind(3, c.issued_at);
    u.bind(4, c.kind);
    u.bind(5, c.body);
    u.bind(6, std::string(commandStatusName(CommandStatus::kPending)));
    const int rc = u.step();
    if (rc != SQLITE_DONE) return error(rc, "cannot store a '" + c.kind + "' command for robot '" + c.robot + "'");
    return static_cast<std::int64_t>(sqlite3_last_insert_rowid(db_));
  }

  Status updateCommand(std::int64_t id, CommandStatus status, const std::string& reason,
                       const std::string& updated_at) override {
    ADIT_RETURN_IF_ERROR(checkCommandUpdate(id, reason, updated_at, where_));
    // The read and the write in one write transaction: two centres on one file answering the
    // same command cannot both move it (PostgreSQL: SELECT ... FOR UPDATE).
    const std::string what = "cannot update command " + std::to_string(id);
    ADIT_RETURN_IF_ERROR(execChecked("BEGIN IMMEDIATE", what));
    Status s = advanceCommand(id, status, reason, updated_at, what);
    if (s.ok()) s = execChecked("COMMIT", what);
    if (!s.ok()) rollback();
    return s;
  }

  StatusOr<std::optional<Command>> command(std::int64_t id) override {
    std::vector<Command> out;
    Use u(command_);
    u.bind(1, static_cast<long long>(id));
    ADIT_RETURN_IF_ERROR(readCommands(u, out, "cannot read command " + std::to_string(id)));
    if (out.empty()) return std::optional<Command>();
    return std::optional<Command>(std::move(out.front()));
  }

  StatusOr<std::vector<Command>> commands(const std::string& robot, std::size_t limit) override {
    std::vector<Command> out;
    Use u(commands_);
    u.bind(1, robot);
    u.bind(2, sqlLimit(limit));
    ADIT_RETURN_IF_ERROR(readCommands(u, out, "cannot read the commands"));
    return out;
  }

  StatusOr<std::vector<Command>> unansweredCommands(const std::string& robot) override {
    std::vector<Command> out;
    Use u(unanswered_);
    u.bind(1, robot);
    ADIT_RETURN_IF_ERROR(readCommands(u, out, "cannot read the unanswered commands of robot '" + robot + "'"));
    return out;
  }

  StatusOr<std::int64_t> addAlarm(const Alarm& a) override {
    ADIT_RETURN_IF_ERROR(checkAlarm(a, where_));
    Use u(add_alarm_);
    u.bind(1, a.robot);
    u.bind(2, a.kind);
    u.bind(3, a.severity);
    u.bind(4, a.message);
    u.bind(5, a.raised_at);
    const int rc = u.step();
    if (rc != SQLITE_DONE) return error(rc, "cannot store a '" + a.kind + "' alarm for robot '" + a.robot + "'");
    return static_cast<std::int64_t>(sqlite3_last_insert_rowid(db_));
  }

  Status clearAlarm(std::int64_t id, const std::string& at) override {
    ADIT_RETURN_IF_ERROR(checkAlarmUpdate(id, {&at}, where_));
    {
      Use u(clear_alarm_);
      u.bind(1, at);
      u.bind(2, static_cast<long long>(id));
      const int rc = u.step();
      if (rc != SQLITE_DONE) return error(rc, "cannot clear alarm " + std::to_string(id));
      if (sqlite3_changes(db_) > 0) return {};
    }
    ADIT_ASSIGN_OR_RETURN(std::optional<Alarm> a, alarm(id));
    if (!a) return notFound(where_ + ": no alarm " + std::to_string(id));
    return {};
  }

  // One conditional UPDATE: of two operators acknowledging at once, one wins and the other is
  // told who did, without a transaction around a read.
  StatusOr<Alarm> acknowledgeAlarm(std::int64_t id, const std::string& operator_name, const std::string& at) override {
    ADIT_RETURN_IF_ERROR(checkAlarmUpdate(id, {&operator_name, &at}, where_));
    bool changed = false;
    {
      Use u(ack_alarm_);
      u.bind(1, at);
      u.bind(2, operator_name);
      u.bind(3, static_cast<long long>(id));
      const int rc = u.step();
      if (rc != SQLITE_DONE) return error(rc, "cannot acknowledge alarm " + std::to_string(id));
      changed = sqlite3_changes(db_) > 0;
    }
    ADIT_ASSIGN_OR_RETURN(std::optional<Alarm> a, alarm(id));
    if (!a) return notFound(where_ + ": no alarm " + std::to_string(id));
    if (!changed) return alreadyAcknowledged(*a, where_);
    return *a;
  }

  StatusOr<std::optional<Alarm>> alarm(std::int64_t id) override {
    std::vector<Alarm> out;
    Use u(alarm_);
    u.bind(1, static_cast<long long>(id));
    ADIT_RETURN_IF_ERROR(readAlarms(u, out, "cannot read alarm " + std::to_string(id)));
    if (out.empty()) return std::optional<Alarm>();
    return std::optional<Alarm>(std::move(out.front()));
  }

  StatusOr<std::vector<Alarm>> alarms(const std::string& robot, bool open_only, std::size_t limit) override {
    std::vector<Alarm> out;
    Use u(alarms_);
    u.bind(1, robot);
    u.bind(2, static_cast<long long>(open_only ? 1 : 0));
    u.bind(3, sqlLimit(limit));
    ADIT_RETURN_IF_ERROR(readAlarms(u, out, "cannot read the alarms"));
    return out;
  }

 private:
  // MigrationTarget. BEGIN IMMEDIATE takes the write lock at once: a second process migrating
  // the same file waits (busy timeout) and then sees the new version.
  Status beginExclusive() override { return execChecked("BEGIN IMMEDIATE", "cannot start a transaction"); }
  Status exec(const std::string& sql) override { return execChecked(sql, "'" + sql + "' failed"); }
  StatusOr<int> currentVersion() override {
    Statement s;
    int rc = sqlite3_prepare_v2(db_, "SELECT coalesce(max(version), 0) FROM schema_migrations", -1, s.out(), nullptr);
    if (rc != SQLITE_OK) return error(rc, "cannot read the schema version");
    Use u(s);
    rc = u.step();
    if (rc != SQLITE_ROW) return error(rc, "cannot read the schema version");
    return static_cast<int>(u.integer(0));
  }
  Status commit() override { return execChecked("COMMIT", "cannot commit"); }
  void rollback() override {
    if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  bool isPostgres() const override { return false; }

  StatusOr<std::size_t> appendBatch(const RobotMessage* messages, std::size_t count) override {
    for (std::size_t i = 0; i < count; ++i) ADIT_RETURN_IF_ERROR(checkMessage(messages[i], where_));
    if (count == 0) return std::size_t{0};
    const std::string what = "cannot store " + batchName(messages, count);
    ADIT_RETURN_IF_ERROR(execChecked("BEGIN IMMEDIATE", what));
    std::size_t fresh = 0;
    Status s;
    for (std::size_t i = 0; i < count && s.ok(); ++i) {
      bool stored = false;
      s = insertMessage(messages[i], what, stored);
      fresh += stored ? 1 : 0;
    }
    // Only duplicates: nothing to flush, end without a commit's fsync.
    if (s.ok() && fresh > 0) s = execChecked("COMMIT", what);
    if (!s.ok() || fresh == 0) rollback();
    if (!s.ok()) return s;
    return fresh;
  }

  Status advanceCommand(std::int64_t id, CommandStatus status, const std::string& reason,
                        const std::string& updated_at, const std::string& what) {
    ADIT_ASSIGN_OR_RETURN(std::optional<Command> current, command(id));
    if (!current) return notFound(where_ + ": no command " + std::to_string(id));
    if (!commandStatusAdvances(current->status, status)) return {};
    Use u(update_command_);
    u.bind(1, std::string(commandStatusName(status)));
    u.bind(2, reason);
    u.bind(3, updated_at);
    u.bind(4, static_cast<long long>(id));
    const int rc = u.step();
    return rc == SQLITE_DONE ? Status() : error(rc, what);
  }

  Status insertMessage(const RobotMessage& m, const std::string& what, bool& fresh) {
    {
      Use u(insert_message_);
      u.bind(1, m.robot);
      u.bind(2, static_cast<long long>(m.seq));
      u.bind(3, m.type);
      u.bind(4, m.t);
      u.bind(5, m.received_at);
      u.bind(6, m.body);
      const int rc = u.step();
      if (rc != SQLITE_DONE) return error(rc, what);
      fresh = sqlite3_changes(db_) > 0;
    }
    if (!fresh || m.type != "telemetry") return {};
    const RobotMessage::Pose& p = *m.pose;
    Use u(insert_telemetry_);
    u.bind(1, m.robot);
    u.bind(2, static_cast<long long>(m.seq));
    u.bind(3, m.t);
    int i = 4;
    for (double v : {p.x, p.y, p.z, p.vx, p.vy, p.vz}) u.bind(i++, v);
    u.bind(10, p.status);
    const int rc = u.step();
    return rc == SQLITE_DONE ? Status() : error(rc, what);
  }

  Status readRobots(Use& u, std::vector<RobotRecord>& out, const std::string& what) {
    int rc;
    while ((rc = u.step()) == SQLITE_ROW)
      out.push_back(robotFromRow(u));
    return rc == SQLITE_DONE ? Status() : error(rc, what);
  }

  Status readCommands(Use& u, std::vector<Command>& out, const std::string& what) {
    int rc;
    while ((rc = u.step()) == SQLITE_ROW) {
      ADIT_ASSIGN_OR_RETURN(Command c, commandFromRow(u, where_));
      out.push_back(std::move(c));
    }
    return rc == SQLITE_DONE ? Status() : error(rc, what);
  }

  Status readAlarms(Use& u, std::vector<Alarm>& out, const std::string& what) {
    int rc;
    while ((rc = u.step()) == SQLITE_ROW) out.push_back(alarmFromRow(u));
    return rc == SQLITE_DONE ? Status() : error(rc, what);
  }

  Status prepareAll() {
    const std::string robot_cols =
        "SELECT r.robot, r.map_hash, r.radius, r.first_seen, r.last_seen,"
        " coalesce((SELECT max(seq) FROM messages m WHERE m.robot = r.robot), 0) FROM robots r";
    const std::string command_cols =
        "SELECT command_id, robot, operator, issued_at, kind, body, status, reason, updated_at FROM commands";
    const std::pair<Statement*, std::string> statements[] = {
        {&upsert_robot_,
         "INSERT INTO robots(robot, map_hash, radius, first_seen, last_seen) VALUES (?1, ?2, ?3, ?4, ?5)"
         " ON CONFLICT(robot) DO UPDATE SET map_hash = excluded.map_hash, radius = excluded.radius,"
         " last_seen = excluded.last_seen"},
        {&robots_, robot_cols + " ORDER BY r.robot"},
        {&robot_, robot_cols + " WHERE r.robot = ?1"},
        {&insert_message_,
         "INSERT INTO messages(robot, seq, type, t, received_at, body) VALUES (?1, ?2, ?3, ?4, ?5, ?6)"
         " ON CONFLICT(robot, seq) DO NOTHING"},
        {&insert_telemetry_,
         "INSERT INTO telemetry(robot, seq, t, x, y, z, vx, vy, vz, status)"
         " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)"},
        {&last_seq_, "SELECT coalesce(max(seq), 0) FROM messages WHERE robot = ?1"},
        {&stored_bytes_, "SELECT coalesce(sum(length(CAST(body AS BLOB))), 0) FROM messages WHERE robot = ?1"},
        {&history_,
         "SELECT m.robot, m.seq, m.type, m.t, m.received_at, m.body, t.x, t.y, t.z, t.vx, t.vy, t.vz, t.status"
         " FROM messages m LEFT JOIN telemetry t ON t.robot = m.robot AND t.seq = m.seq"
         " WHERE m.robot = ?1 AND m.seq >= ?2 ORDER BY m.seq LIMIT ?3"},
        // Walks the (robot, seq) primary key backwards from the robot's newest row.
        {&last_of_type_,
         "SELECT robot, seq, type, t, received_at, body FROM messages WHERE robot = ?1 AND type = ?2"
         " ORDER BY seq DESC LIMIT 1"},
        {&telemetry_rows_, "SELECT count(*) FROM telemetry"},
        {&add_command_,
         "INSERT INTO commands(robot, operator, issued_at, kind, body, status, reason, updated_at)"
         " VALUES (?1, ?2, ?3, ?4, ?5, ?6, '', ?3)"},
        {&update_command_, "UPDATE commands SET status = ?1, reason = ?2, updated_at = ?3 WHERE command_id = ?4"},
        {&command_, command_cols + " WHERE command_id = ?1"},
        {&commands_,
         "SELECT * FROM (" + command_cols + " WHERE ?1 = '' OR robot = ?1 ORDER BY command_id DESC LIMIT ?2)"
         " ORDER BY command_id"},
        {&unanswered_,
         command_cols + " WHERE robot = ?1 AND status IN ('pending', 'sent') ORDER BY command_id"},
        {&add_alarm_,
         "INSERT INTO alarms(robot, kind, severity, message, raised_at) VALUES (?1, ?2, ?3, ?4, ?5)"},
        {&clear_alarm_, "UPDATE alarms SET cleared_at = ?1 WHERE alarm_id = ?2 AND cleared_at = ''"},
        {&ack_alarm_, "UPDATE alarms SET acked_at = ?1, acked_by = ?2 WHERE alarm_id = ?3 AND acked_at = ''"},
        {&alarm_, std::string(kAlarmColumns) + " WHERE alarm_id = ?1"},
        {&alarms_,
         "SELECT * FROM (" + std::string(kAlarmColumns) +
             " WHERE (?1 = '' OR robot = ?1) AND (?2 = 0 OR cleared_at = '' OR acked_at = '')"
             " ORDER BY alarm_id DESC LIMIT ?3) ORDER BY alarm_id"},
    };
    for (const auto& [stmt, sql] : statements) {
      const int rc = sqlite3_prepare_v3(db_, sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, stmt->out(), nullptr);
      if (rc != SQLITE_OK) return error(rc, "cannot prepare '" + sql + "'");
    }
    return {};
  }

  /// Switching a fresh file to WAL needs it exclusively, and SQLite answers "database is locked"
  /// at once, without the busy handler, when another centre opening the same file holds it:
  /// retry for as long as the busy timeout. Once a file is in WAL mode it stays so (the mode
  /// is stored in the file), and the pragma no longer contends.
  Status switchToWal() {
    int rc = SQLITE_OK;
    for (int attempt = 0; attempt < 500; ++attempt) {
      rc = sqlite3_exec(db_, "PRAGMA journal_mode=WAL", nullptr, nullptr, nullptr);
      if ((rc & 0xff) != SQLITE_BUSY && (rc & 0xff) != SQLITE_LOCKED) break;
      sqlite3_sleep(10);
    }
    return rc == SQLITE_OK ? Status() : error(rc, "cannot switch to WAL");
  }

  Status execChecked(const std::string& sql, const std::string& what) {
    const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr);
    return rc == SQLITE_OK ? Status() : error(rc, what);
  }

  Status error(int rc, const std::string& what) const {
    const char* detail = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    return Status(codeOf(rc), where_ + ": " + what + ": " + detail);
  }

  std::string path_, where_;
  bool synchronous_full_;
  sqlite3* db_ = nullptr;
  Statement upsert_robot_, robots_, robot_, insert_message_, insert_telemetry_, last_seq_, stored_bytes_, history_, last_of_type_,
      telemetry_rows_, add_command_, update_command_, command_, commands_, unanswered_, add_alarm_, clear_alarm_,
      ack_alarm_, alarm_, alarms_;
};

}  // namespace

StatusOr<std::unique_ptr<Store>> openSqlite(const std::string& path, bool synchronous_full) {
  auto store = std::make_unique<SqliteStore>(path, synchronous_full);
  ADIT_RETURN_IF_ERROR(store->open());
  return std::unique_ptr<Store>(std::move(store));
}

}  // namespace adit::console::detail
