// SPDX-License-Identifier: BSD-3-Clause
// The shared backend (libpqxx). Durability: PostgreSQL's default synchronous_commit=on makes
// COMMIT return only once the transaction's WAL is flushed, so appendMessage() returning means
// the message survives a crash of the centre and of the database server; it is set explicitly
// per session so a server configured otherwise cannot weaken the acknowledgement.
#include <pqxx/pqxx>

#include <utility>

#include "store_internal.hpp"

namespace adit::console::detail {
namespace {

/// The password of a postgresql:// URL (user:PASSWORD@ or password=PASSWORD), "" if none.
std::string passwordOf(const std::string& url) {
  const std::size_t key = url.find("password=");
  if (key != std::string::npos) {
    const std::size_t start = key + 9;
    return url.substr(start, url.find_first_of("& ", start) - start);
  }
  const std::size_t host_start = url.find("://");
  if (host_start == std::string::npos) return "";
  const std::size_t at = url.find('@', host_start + 3);
  const std::size_t slash = url.find('/', host_start + 3);
  if (at == std::string::npos || (slash != std::string::npos && slash < at)) return "";
  const std::size_t colon = url.find(':', host_start + 3);
  if (colon == std::string::npos || colon > at) return "";
  return url.substr(colon + 1, at - colon - 1);
}

std::string text(const pqxx::field& f) { return f.is_null() ? std::string() : std::string(f.c_str(), f.size()); }
long long integer(const pqxx::field& f) { return f.is_null() ? 0 : f.as<long long>(); }

/// A libpqxx row seen through the shared decoders' column interface (store_internal.hpp).
struct Row {
  const pqxx::row& row;
  std::string text(int i) const { return detail::text(row[i]); }
  double real(int i) const { return row[i].is_null() ? 0.0 : row[i].as<double>(); }
  long long integer(int i) const { return detail::integer(row[i]); }
  bool isNull(int i) const { return row[i].is_null(); }
};

class PostgresStore final : public Store, private MigrationTarget {
 public:
  explicit PostgresStore(std::string url)
      : url_(std::move(url)), password_(passwordOf(url_)), where_(redactUrl(url_)) {}

  Status open() {
    ADIT_RETURN_IF_ERROR(guard(
        "cannot connect",
        [&]() -> Status {
          connect();
          return {};
        },
        Retry::kNever));
    ADIT_RETURN_IF_ERROR(applyMigrations(*this, where_));
    return guard(
        "cannot prepare the statements",
        [&]() -> Status {
          prepareAll();
          ready_ = true;
          return {};
        },
        Retry::kNever);
  }

  std::string backend() const override { return "postgresql"; }

  StatusOr<int> schemaVersion() override {
    return guard("cannot read the schema version", [&]() -> StatusOr<int> {
      pqxx::read_transaction txn(*conn_);
      return txn.exec1("SELECT coalesce(max(version), 0) FROM schema_migrations")[0].as<int>();
    });
  }

  Status upsertRobot(const RobotRecord& r) override {
    ADIT_RETURN_IF_ERROR(checkRobot(r, where_));
    return guard("cannot store robot '" + r.robot + "'", [&]() -> Status {
      pqxx::work txn(*conn_);
      txn.exec_prepared0("upsert_robot", r.robot, r.map_hash, r.radius,
                         r.first_seen.empty() ? r.last_seen : r.first_seen, r.last_seen);
      txn.commit();
      return {};
    });
  }

  StatusOr<std::vector<RobotRecord>> robots() override {
    return guard("cannot read the robots", [&]() -> StatusOr<std::vector<RobotRecord>> {
      pqxx::read_transaction txn(*conn_);
      return toRobots(txn.exec_prepared("robots"));
    });
  }

  StatusOr<std::optional<RobotRecord>> robot(const std::string& robot) override {
    return guard("cannot read robot '" + robot + "'", [&]() -> StatusOr<std::optional<RobotRecord>> {
      pqxx::read_transaction txn(*conn_);
      std::vector<RobotRecord> found = toRobots(txn.exec_prepared("robot", robot));
      if (found.empty()) return std::optional<RobotRecord>();
      return std::optional<RobotRecord>(std::move(found.front()));
    });
  }

  StatusOr<std::int64_t> lastSeq(const std::string& robot) override {
    return guard("cannot read the last seq of robot '" + robot + "'", [&]() -> StatusOr<std::int64_t> {
      pqxx::read_transaction txn(*conn_);
      return static_cast<std::int64_t>(integer(txn.exec_prepared1("last_seq", robot)[0]));
    });
  }

  StatusOr<std::int64_t> storedBytes(const std::string& robot) override {
    return guard("cannot read the stored bytes of robot '" + robot + "'", [&]() -> StatusOr<std::int64_t> {
      pqxx::read_transaction txn(*conn_);
      return static_cast<std::int64_t>(integer(txn.exec_prepared1("stored_bytes", robot)[0]));
    });
  }

  StatusOr<std::vector<RobotMessage>> history(const std::string& robot, std::int64_t from_seq, std::size_t limit,
                                              std::size_t max_bytes) override {
    return guard("cannot read the history of robot '" + robot + "'", [&]() -> StatusOr<std::vector<RobotMessage>> {
      // Two index range scans merged here rather than a LEFT JOIN: on tables without fresh
      // statistics PostgreSQL's generic plan for the prepared join was a nested loop with a join
      // filter, quadratic in the rows (50 ms for a 1,000-message replay instead of 3).
      pqxx::read_transaction txn(*conn_);
      const pqxx::result r =
          txn.exec_prepared("history", robot, static_cast<long long>(from_seq), sqlLimit(limit),
                            static_cast<long long>(std::min<std::size_t>(max_bytes, std::size_t{1} << 62)));
      std::vector<RobotMessage> out;
      out.reserve(r.size());
      for (const pqxx::row& row : r) out.push_back(messageFromRow(Row{row}));
      if (out.empty()) return out;
      const pqxx::result poses = txn.exec_prepared("history_poses", robot, static_cast<long long>(out.front().seq),
                                                   static_cast<long long>(out.back().seq));
      auto it = out.begin();
      for (const pqxx::row& row : poses) {
        const std::int64_t seq = integer(row[0]);
        while (it != out.end() && it->seq < seq) ++it;
        if (it != out.end() && it->seq == seq) it->pose = poseFromRow(Row{row}, 1);
      }
      return out;
    });
  }

  StatusOr<std::optional<RobotMessage>> lastOfType(const std::string& robot, const std::string& type) override {
    return guard("cannot read the last " + type + " of robot '" + robot + "'",
                 [&]() -> StatusOr<std::optional<RobotMessage>> {
                   pqxx::read_transaction txn(*conn_);
                   const pqxx::result r = txn.exec_prepared("last_of_type", robot, type);
                   if (r.empty()) return std::optional<RobotMessage>();
                   return std::optional<RobotMessage>(messageFromRow(Row{r[0]}));
                 });
  }

  StatusOr<std::int64_t> telemetryRows() override {
    return guard("cannot count the telemetry rows", [&]() -> StatusOr<std::int64_t> {
      pqxx::read_transaction txn(*conn_);
      return static_cast<std::int64_t>(integer(txn.exec_prepared1("telemetry_rows")[0]));
    });
  }

  StatusOr<std::int64_t> addCommand(const Command& c) override {
    ADIT_RETURN_IF_ERROR(checkCommand(c, where_));
    return guard("cannot store a '" + c.kind + "' command for robot '" + c.robot + "'", [&]() -> StatusOr<std::int64_t> {
      pqxx::work txn(*conn_);
      const long long id = integer(txn.exec_prepared1("add_command", c.robot, c.operator_name, c.issued_at, c.kind,
                                                      c.body, commandStatusName(CommandStatus::kPending))[0]);
      txn.commit();
      return static_cast<std::int64_t>(id);
    }, Retry::kNever);
  }

  Status updateCommand(std::int64_t id, CommandStatus status, const std::string& reason,
                       const std::string& updated_at) override {
    ADIT_RETURN_IF_ERROR(checkCommandUpdate(id, reason, updated_at, where_));
    return guard("cannot update command " + std::to_string(id), [&]() -> Status {
      pqxx::work txn(*conn_);
      // FOR UPDATE: two centres answering the same command serialise on its row.
      const pqxx::result r = txn.exec_prepared("lock_command", static_cast<long long>(id));
      if (r.empty()) return notFound(where_ + ": no command " + std::to_string(id));
      const std::optional<CommandStatus> current = parseCommandStatus(text(r[0][0]));
      if (!current) return dataLoss(where_ + ": command " + std::to_string(id) + " has an unknown status '" + text(r[0][0]) + "'");
      if (!commandStatusAdvances(*current, status)) return {};
      txn.exec_prepared0("update_command", commandStatusName(status), reason, updated_at, static_cast<long long>(id));
      txn.commit();
      return {};
    });
  }

  StatusOr<std::optional<Command>> command(std::int64_t id) override {
    return guard("cannot read command " + std::to_string(id), [&]() -> StatusOr<std::optional<Command>> {
      pqxx::read_transaction txn(*conn_);
      ADIT_ASSIGN_OR_RETURN(std::vector<Command> found, toCommands(txn.exec_prepared("command", static_cast<long long>(id))));
      if (found.empty()) return std::optional<Command>();
      return std::optional<Command>(std::move(found.front()));
    });
  }

  StatusOr<std::vector<Command>> commands(const std::string& robot, std::size_t limit) override {
    return guard("cannot read the commands", [&]() -> StatusOr<std::vector<Command>> {
      pqxx::read_transaction txn(*conn_);
      return toCommands(txn.exec_prepared("commands", robot, sqlLimit(limit)));
    });
  }

  StatusOr<std::vector<Command>> unansweredCommands(const std::string& robot) override {
    return guard("cannot read the unanswered commands of robot '" + robot + "'", [&]() -> StatusOr<std::vector<Command>> {
      pqxx::read_transaction txn(*conn_);
      return toCommands(txn.exec_prepared("unanswered", robot));
    });
  }

  StatusOr<std::int64_t> addAlarm(const Alarm& a) override {
    ADIT_RETURN_IF_ERROR(checkAlarm(a, where_));
    // Not retried, as addCommand: a retried INSERT whose COMMIT landed would raise it twice.
    return guard("cannot store a '" + a.kind + "' alarm for robot '" + a.robot + "'", [&]() -> StatusOr<std::int64_t> {
      pqxx::work txn(*conn_);
      const long long id =
          integer(txn.exec_prepared1("add_alarm", a.robot, a.kind, a.severity, a.message, a.raised_at)[0]);
      txn.commit();
      return static_cast<std::int64_t>(id);
    }, Retry::kNever);
  }

  Status clearAlarm(std::int64_t id, const std::string& at) override {
    ADIT_RETURN_IF_ERROR(checkAlarmUpdate(id, {&at}, where_));
    return guard("cannot clear alarm " + std::to_string(id), [&]() -> Status {
      pqxx::work txn(*conn_);
      const pqxx::result r = txn.exec_prepared("clear_alarm", at, static_cast<long long>(id));
      if (r.empty() && txn.exec_prepared("alarm", static_cast<long long>(id)).empty())
        return notFound(where_ + ": no alarm " + std::to_string(id));
      txn.commit();
      return {};
    });
  }

  // One conditional UPDATE ... RETURNING: of two operators acknowledging at once, one wins and
  // the other is told who did.
  StatusOr<Alarm> acknowledgeAlarm(std::int64_t id, const std::string& operator_name, const std::string& at) override {
    ADIT_RETURN_IF_ERROR(checkAlarmUpdate(id, {&operator_name, &at}, where_));
    return guard("cannot acknowledge alarm " + std::to_string(id), [&]() -> StatusOr<Alarm> {
      pqxx::work txn(*conn_);
      const pqxx::result r = txn.exec_prepared("ack_alarm", at, operator_name, static_cast<long long>(id));
      if (!r.empty()) {
        Alarm a = alarmFromRow(Row{r[0]});
        txn.commit();
        return a;
      }
      const pqxx::result now = txn.exec_prepared("alarm", static_cast<long long>(id));
      if (now.empty()) return notFound(where_ + ": no alarm " + std::to_string(id));
      return alreadyAcknowledged(alarmFromRow(Row{now[0]}), where_);
    });
  }

  StatusOr<std::optional<Alarm>> alarm(std::int64_t id) override {
    return guard("cannot read alarm " + std::to_string(id), [&]() -> StatusOr<std::optional<Alarm>> {
      pqxx::read_transaction txn(*conn_);
      const pqxx::result r = txn.exec_prepared("alarm", static_cast<long long>(id));
      if (r.empty()) return std::optional<Alarm>();
      return std::optional<Alarm>(alarmFromRow(Row{r[0]}));
    });
  }

  StatusOr<std::vector<Alarm>> alarms(const std::string& robot, bool open_only, std::size_t limit) override {
    return guard("cannot read the alarms", [&]() -> StatusOr<std::vector<Alarm>> {
      pqxx::read_transaction txn(*conn_);
      std::vector<Alarm> out;
      for (const pqxx::row& row : txn.exec_prepared("alarms", robot, open_only, sqlLimit(limit)))
        out.push_back(alarmFromRow(Row{row}));
      return out;
    });
  }

 private:
  // MigrationTarget. A transaction-scoped advisory lock (the key is arbitrary but fixed) makes a
  // second centre starting at the same time wait for the first one's migration.
  Status beginExclusive() override {
    return guard("cannot start a migration transaction", [&]() -> Status {
      txn_ = std::make_unique<pqxx::work>(*conn_, "migration");
      txn_->exec("SELECT pg_advisory_xact_lock(7111002011)");
      return {};
    }, Retry::kNever);
  }
  Status exec(const std::string& sql) override {
    return guard("'" + sql + "' failed", [&]() -> Status {
      ADIT_DEMAND(txn_);  // applyMigrations stops at the first failed step
      txn_->exec0(sql);
      return {};
    }, Retry::kNever);
  }
  StatusOr<int> currentVersion() override {
    return guard("cannot read the schema version", [&]() -> StatusOr<int> {
      ADIT_DEMAND(txn_);
      return txn_->exec1("SELECT coalesce(max(version), 0) FROM schema_migrations")[0].as<int>();
    }, Retry::kNever);
  }
  Status commit() override {
    return guard("cannot commit", [&]() -> Status {
      ADIT_DEMAND(txn_);
      txn_->commit();
      txn_.reset();
      return {};
    }, Retry::kNever);
  }
  void rollback() override {
    // pqxx::work aborts in its destructor, which never throws.
    txn_.reset();
  }
  bool isPostgres() const override { return true; }

  StatusOr<std::size_t> appendBatch(const RobotMessage* messages, std::size_t count) override {
    for (std::size_t i = 0; i < count; ++i) ADIT_RETURN_IF_ERROR(checkMessage(messages[i], where_));
    if (count == 0) return std::size_t{0};
    return guard("cannot store " + batchName(messages, count), [&]() -> StatusOr<std::size_t> {
      pqxx::work txn(*conn_);
      std::size_t fresh = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const RobotMessage& m = messages[i];
        const pqxx::result r = txn.exec_prepared("insert_message", m.robot, static_cast<long long>(m.seq), m.type,
                                                 m.t, m.received_at, m.body);
        if (r.affected_rows() == 0) continue;  // stored already
        ++fresh;
        if (m.type == "telemetry") {
          const RobotMessage::Pose& p = *m.pose;
          txn.exec_prepared0("insert_telemetry", m.robot, static_cast<long long>(m.seq), m.t, p.x, p.y, p.z,
                             p.vx, p.vy, p.vz, p.status);
        }
      }
      if (fresh > 0) txn.commit();  // else the work aborts: nothing to flush
      return fresh;
    });
  }

  void prepareAll() {
    const std::string robot_cols =
        "SELECT r.robot, r.map_hash, r.radius, r.first_seen, r.last_seen,"
        " coalesce((SELECT max(seq) FROM messages m WHERE m.robot = r.robot), 0) FROM robots r";
    const std::string command_cols =
        "SELECT command_id, robot, operator, issued_at, kind, body, status, reason, updated_at FROM commands";
    conn_->prepare("upsert_robot",
                   "INSERT INTO robots(robot, map_hash, radius, first_seen, last_seen) VALUES ($1, $2, $3, $4, $5)"
                   " ON CONFLICT (robot) DO UPDATE SET map_hash = excluded.map_hash, radius = excluded.radius,"
                   " last_seen = excluded.last_seen");
    conn_->prepare("robots", robot_cols + " ORDER BY r.robot");
    conn_->prepare("robot", robot_cols + " WHERE r.robot = $1");
    conn_->prepare("insert_message",
                   "INSERT INTO messages(robot, seq, type, t, received_at, body) VALUES ($1, $2, $3, $4, $5, $6)"
                   " ON CONFLICT (robot, seq) DO NOTHING");
    conn_->prepare("insert_telemetry",
                   "INSERT INTO telemetry(robot, seq, t, x, y, z, vx, vy, vz, status)"
                   " VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10)");
    conn_->prepare("last_seq", "SELECT coalesce(max(seq), 0) FROM messages WHERE robot = $1");
    conn_->prepare("stored_bytes", "SELECT coalesce(sum(octet_length(body)), 0)::BIGINT FROM messages WHERE robot = $1");
    // The byte budget is applied in the database: the bodies past it never reach libpq's result
    // (which holds a whole result in memory).
    conn_->prepare("history",
                   "SELECT robot, seq, type, t, received_at, body FROM ("
                   "SELECT robot, seq, type, t, received_at, body,"
                   " sum(octet_length(body)) OVER (ORDER BY seq) - octet_length(body) AS before"
                   " FROM messages WHERE robot = $1 AND seq >= $2 ORDER BY seq LIMIT $3) page"
                   " WHERE before < $4 ORDER BY seq");
    conn_->prepare("history_poses",
                   "SELECT seq, x, y, z, vx, vy, vz, status FROM telemetry"
                   " WHERE robot = $1 AND seq >= $2 AND seq <= $3 ORDER BY seq");
    // A backward scan of the (robot, seq) primary key from the robot's newest row.
    conn_->prepare("last_of_type",
                   "SELECT robot, seq, type, t, received_at, body FROM messages"
                   " WHERE robot = $1 AND type = $2 ORDER BY seq DESC LIMIT 1");
    conn_->prepare("telemetry_rows", "SELECT count(*) FROM telemetry");
    conn_->prepare("add_command",
                   "INSERT INTO commands(robot, operator, issued_at, kind, body, status, reason, updated_at)"
                   " VALUES ($1, $2, $3, $4, $5, $6, '', $3) RETURNING command_id");
    conn_->prepare("lock_command", "SELECT status FROM commands WHERE command_id = $1 FOR UPDATE");
    conn_->prepare("update_command",
                   "UPDATE commands SET status = $1, reason = $2, updated_at = $3 WHERE command_id = $4");
    conn_->prepare("command", command_cols + " WHERE command_id = $1");
    conn_->prepare("commands", "SELECT * FROM (" + command_cols +
                                   " WHERE $1 = '' OR robot = $1 ORDER BY command_id DESC LIMIT $2) newest"
                                   " ORDER BY command_id");
    conn_->prepare("unanswered",
                   command_cols + " WHERE robot = $1 AND status IN ('pending', 'sent') ORDER BY command_id");
    const std::string alarm_cols = kAlarmColumns;
    const std::string returning = " RETURNING alarm_id, robot, kind, severity, message, raised_at, cleared_at, acked_at, acked_by";
    conn_->prepare("add_alarm",
                   "INSERT INTO alarms(robot, kind, severity, message, raised_at) VALUES ($1, $2, $3, $4, $5)"
                   " RETURNING alarm_id");
    conn_->prepare("clear_alarm",
                   "UPDATE alarms SET cleared_at = $1 WHERE alarm_id = $2 AND cleared_at = '' RETURNING alarm_id");
    conn_->prepare("ack_alarm",
                   "UPDATE alarms SET acked_at = $1, acked_by = $2 WHERE alarm_id = $3 AND acked_at = ''" + returning);
    conn_->prepare("alarm", alarm_cols + " WHERE alarm_id = $1");
    conn_->prepare("alarms", "SELECT * FROM (" + alarm_cols +
                                 " WHERE ($1 = '' OR robot = $1) AND (NOT $2::BOOLEAN OR cleared_at = '' OR acked_at = '')"
                                 " ORDER BY alarm_id DESC LIMIT $3) newest ORDER BY alarm_id");
  }

  static std::vector<RobotRecord> toRobots(const pqxx::result& r) {
    std::vector<RobotRecord> out;
    for (const pqxx::row& row : r)
      out.push_back(robotFromRow(Row{row}));
    return out;
  }

  StatusOr<std::vector<Command>> toCommands(const pqxx::result& r) const {
    std::vector<Command> out;
    for (const pqxx::row& row : r) {
      ADIT_ASSIGN_OR_RETURN(Command c, commandFromRow(Row{row}, where_));
      out.push_back(std::move(c));
    }
    return out;
  }

  /// Opens the session (no statement prepared yet: open() prepares after the migrations).
  void connect() {
    conn_ = std::make_unique<pqxx::connection>(url_);
    pqxx::nontransaction setup(*conn_);
    // CREATE TABLE IF NOT EXISTS would print a NOTICE on stderr at every start otherwise.
    setup.exec0("SET client_min_messages = warning");
    setup.exec0("SET synchronous_commit = on");
  }

  /// Forgets a broken connection; the next call opens a new one.
  void dropConnection() {
    txn_.reset();
    conn_.reset();
  }

  /// Whether a call that met a dropped connection is retried once on a new one. Every call is,
  /// except addCommand (retrying an INSERT whose COMMIT may have landed could issue the command
  /// twice) and the migration steps (their transaction died with the connection). The others
  /// are idempotent: a message is stored at most once per (robot, seq) (a retry of a landed
  /// commit answers "stored already", and the server acknowledges it all the same), commands
  /// only move forward, robots are upserted.
  enum class Retry { kOnce, kNever };

  /// Runs f, turning libpqxx's exceptions into a Status that names the (redacted) URL.
  template <class F>
  auto guard(const std::string& what, F&& f, Retry retry = Retry::kOnce) -> decltype(f()) {
    for (int attempt = 0;; ++attempt) {
      const bool may_retry = retry == Retry::kOnce && attempt == 0;
      try {
        if (!conn_ && ready_) {
          connect();
          prepareAll();
        }
        return f();
      } catch (const pqxx::broken_connection& e) {
        dropConnection();
        if (may_retry) continue;
        return Status(StatusCode::kFailedPrecondition, where_ + ": " + what + ": " + scrub(e.what()));
      } catch (const pqxx::in_doubt_error& e) {
        dropConnection();
        if (may_retry) continue;
        return Status(StatusCode::kInternal, where_ + ": " + what +
                                                 ": the connection was lost during COMMIT, its outcome is unknown: " +
                                                 scrub(e.what()));
      } catch (const pqxx::data_exception& e) {
        return Status(StatusCode::kInvalidArgument, where_ + ": " + what + ": " + scrub(e.what()));
      } catch (const std::exception& e) {
        return Status(StatusCode::kInternal, where_ + ": " + what + ": " + scrub(e.what()));
      }
    }
  }

  /// libpq's messages do not normally quote the password; make sure of it, and drop the
  /// trailing newline libpq adds.
  std::string scrub(std::string message) const {
    if (!password_.empty())
      for (std::size_t p = message.find(password_); p != std::string::npos; p = message.find(password_, p))
        message.replace(p, password_.size(), "***");
    while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
    return message;
  }

  std::string url_, password_, where_;
  std::unique_ptr<pqxx::connection> conn_;
  std::unique_ptr<pqxx::work> txn_;  // the migration's (destroyed before conn_)
  bool ready_ = false;  // migrated and prepared: a dropped connection may be reopened
};

}  // namespace

StatusOr<std::unique_ptr<Store>> openPostgres(const std::string& url) {
  auto store = std::make_unique<PostgresStore>(url);
  ADIT_RETURN_IF_ERROR(store->open());
  return std::unique_ptr<Store>(std::move(store));
}

}  // namespace adit::console::detail
