// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// What the two Store backends share: the versioned schema (one migration list, with each
/// statement spelled for SQLite and for PostgreSQL), the migration procedure, the checks every
/// message and command passes before anything is written, and the URL redaction that keeps a
/// PostgreSQL password out of every error message.

#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "adit/console/store.hpp"

namespace adit::console::detail {

struct Migration {
  int version;
  std::vector<std::string> sqlite;    ///< statements, run in order in one transaction
  std::vector<std::string> postgres;
};
/// Versions 1..kSchemaVersion, in order.
const std::vector<Migration>& migrations();

/// The few operations the migration procedure needs from a backend.
class MigrationTarget {
 public:
  virtual ~MigrationTarget() = default;
  /// Starts a transaction that excludes every other migrating process until it ends.
  virtual Status beginExclusive() = 0;
  virtual Status exec(const std::string& sql) = 0;
  /// max(version) of schema_migrations, 0 for an empty table.
  virtual StatusOr<int> currentVersion() = 0;
  virtual Status commit() = 0;
  virtual void rollback() = 0;
  virtual bool isPostgres() const = 0;
};

/// Creates schema_migrations when missing, refuses a database newer than this build, then
/// applies the missing migrations in order, one transaction each (each one re-reads the version
/// under the exclusive lock, so two centres starting at once do not both migrate). `where`
/// (the redacted URL) prefixes every error.
Status applyMigrations(MigrationTarget& db, const std::string& where);

/// `postgresql://user:secret@host/db` → `postgresql://user:***@host/db`; also a `password=`
/// query parameter or keyword. Anything else is returned unchanged.
std::string redactUrl(const std::string& url);

/// The centre's wall clock, ISO 8601 UTC with milliseconds ("2026-11-30T23:15:28.123Z").
std::string nowUtc();

/// "message (robot 'r1', seq 42)", for errors.
std::string messageName(const RobotMessage& m);
/// "message (robot 'r1', seq 42)" or "batch of 3 messages (robot 'r1', seq 42 ...)".
std::string batchName(const RobotMessage* messages, std::size_t count);

Status checkMessage(const RobotMessage& m, const std::string& where);
Status checkRobot(const RobotRecord& r, const std::string& where);
Status checkCommand(const Command& c, const std::string& where);
Status checkCommandUpdate(std::int64_t id, const std::string& reason, const std::string& updated_at,
                          const std::string& where);

Status checkAlarm(const Alarm& a, const std::string& where);
Status checkAlarmUpdate(std::int64_t id, std::initializer_list<const std::string*> texts, const std::string& where);

/// Commands only move forward: pending → sent → accepted → executed, or → refused from any
/// unanswered state; executed and refused are final. A repeated or late answer (the robot
/// answers a resent command again with its stored result) leaves the stored state as it is.
bool commandStatusAdvances(CommandStatus from, CommandStatus to);

/// Row decoders shared by the backends. `Row` reads column i as text(i), real(i), integer(i)
/// and isNull(i); the columns are in the order of the backends' SELECTs.
/// messages: robot, seq, type, t, received_at, body
template <class Row>
RobotMessage messageFromRow(const Row& row) {
  RobotMessage m;
  m.robot = row.text(0);
  m.seq = row.integer(1);
  m.type = row.text(2);
  m.t = row.real(3);
  m.received_at = row.text(4);
  m.body = row.text(5);
  return m;
}

/// telemetry from column `c` on: x, y, z, vx, vy, vz, status
template <class Row>
RobotMessage::Pose poseFromRow(const Row& row, int c) {
  return {row.real(c), row.real(c + 1), row.real(c + 2), row.real(c + 3), row.real(c + 4), row.real(c + 5),
          row.text(c + 6)};
}

/// robots r: robot, map_hash, radius, first_seen, last_seen, last_seq
template <class Row>
RobotRecord robotFromRow(const Row& row) {
  return {row.text(0), row.text(1), row.real(2), row.text(3), row.text(4), row.integer(5)};
}

/// commands: command_id, robot, operator, issued_at, kind, body, status, reason, updated_at.
/// A status this build does not know is corrupt data, reported naming the command.
template <class Row>
StatusOr<Command> commandFromRow(const Row& row, const std::string& where) {
  Command c;
  c.command_id = row.integer(0);
  c.robot = row.text(1);
  c.operator_name = row.text(2);
  c.issued_at = row.text(3);
  c.kind = row.text(4);
  c.body = row.text(5);
  const std::optional<CommandStatus> status = parseCommandStatus(row.text(6));
  if (!status)
    return dataLoss(where + ": command " + std::to_string(c.command_id) + " has an unknown status '" +
                    row.text(6) + "'");
  c.status = *status;
  c.reason = row.text(7);
  c.updated_at = row.text(8);
  return c;
}

/// alarms: alarm_id, robot, kind, severity, message, raised_at, cleared_at, acked_at, acked_by
template <class Row>
Alarm alarmFromRow(const Row& row) {
  Alarm a;
  a.alarm_id = row.integer(0);
  a.robot = row.text(1);
  a.kind = row.text(2);
  a.severity = row.text(3);
  a.message = row.text(4);
  a.raised_at = row.text(5);
  a.cleared_at = row.text(6);
  a.acked_at = row.text(7);
  a.acked_by = row.text(8);
  return a;
}
inline constexpr const char* kAlarmColumns =
    "SELECT alarm_id, robot, kind, severity, message, raised_at, cleared_at, acked_at, acked_by FROM alarms";

/// "alarm 7 was acknowledged by alice at 2026-...", the refusal of a second acknowledgement.
Status alreadyAcknowledged(const Alarm& a, const std::string& where);

/// Clamps a caller's row limit to what SQL LIMIT takes.
long long sqlLimit(std::size_t limit);

/// synchronous_full false: PRAGMA synchronous=NORMAL (see store_sqlite.cpp).
StatusOr<std::unique_ptr<Store>> openSqlite(const std::string& path, bool synchronous_full);
StatusOr<std::unique_ptr<Store>> openPostgres(const std::string& url);

}  // namespace adit::console::detail
