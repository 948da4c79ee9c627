// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The data exchange centre's database (issue 11; Guo 2022 §1 keeps it in MySQL): every robot
/// message, the poses, and every operator command with who issued it, when, and what the robot
/// did with it. Two backends behind one interface: SQLite, embedded, nothing to set up
/// (`sqlite:PATH`), and PostgreSQL for a centre shared by several robots and operators
/// (`postgresql://user@host:port/db`, libpqxx). The schema is versioned: open() applies the
/// missing migrations in order, one transaction each, and refuses a database newer than this
/// build. Each robot message is stored in one transaction, at most once per (robot, seq), so a
/// robot that resends after a lost connection or a restarted centre never duplicates a row.
/// The protocol and table layout: console/doc/protocol.md.
///
///   StatusOr<std::unique_ptr<Store>> db = Store::open("sqlite:/var/lib/adit/centre.db");
///   StatusOr<bool> fresh = (*db)->appendMessage(msg);  // false: (robot, seq) was stored already
///
/// A Store is used from one thread at a time (the server's I/O thread); it is not thread-safe.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/console/protocol_limits.hpp"
#include "adit/status.hpp"

namespace adit::console {

/// The schema version this build writes and reads.
inline constexpr int kSchemaVersion = 2;  ///< 2: the alarms table

/// One robot → centre message as stored (protocol.md, "robot → centre"), `hello` excluded.
struct RobotMessage {
  std::string robot;
  std::int64_t seq = 0;
  std::string type;          ///< telemetry, plan, obstacles, event, command_result
  double t = 0.0;            ///< the robot's mission clock [s]
  std::string received_at;   ///< the centre's clock, ISO 8601 UTC (set by the caller)
  std::string body;          ///< the whole message as JSON text
  /// For type == "telemetry": the typed row (position, velocity, status). Required then.
  struct Pose {
    double x = 0, y = 0, z = 0, vx = 0, vy = 0, vz = 0;
    std::string status;
  };
  std::optional<Pose> pose;
};

enum class CommandStatus { kPending, kSent, kAccepted, kRefused, kExecuted };
const char* commandStatusName(CommandStatus s);
std::optional<CommandStatus> parseCommandStatus(const std::string& name);

struct Command {
  std::int64_t command_id = 0;  ///< assigned by addCommand()
  std::string robot;
  std::string operator_name;
  std::string issued_at;
  std::string kind;             ///< pause, resume, goal, block, reopen, manual, release, estop, estop_release
  std::string body;             ///< the command as JSON text (its arguments)
  CommandStatus status = CommandStatus::kPending;
  std::string reason;
  std::string updated_at;
};

/// A condition an operator must see and acknowledge (console/doc/protocol.md, "Alarms"): raised
/// by the centre, cleared when the condition ends, acknowledged by an operator; it stays open
/// (shown) until it is both.
struct Alarm {
  std::int64_t alarm_id = 0;  ///< assigned by addAlarm()
  std::string robot;
  std::string kind;           ///< stale_telemetry, lost_link, clearance, stuck, collision, no_route
  std::string severity;       ///< critical, major, minor
  std::string message;        ///< what was seen, in words (e.g. "clearance 0.12 m below the margin 0.20 m")
  std::string raised_at;      ///< the centre's clock, ISO 8601 UTC
  std::string cleared_at;     ///< "" while the condition holds
  std::string acked_at;       ///< "" until an operator acknowledges it
  std::string acked_by;       ///< the operator's name
  bool open() const { return cleared_at.empty() || acked_at.empty(); }
};

struct RobotRecord {
  std::string robot;
  std::string map_hash;
  double radius = 0.0;
  std::string first_seen, last_seen;
  std::int64_t last_seq = 0;    ///< highest stored seq (0: none)
};

class Store {
 public:
  /// `sqlite:PATH` (created if missing) or `postgresql://...` / `postgres://...`. Applies the
  /// missing migrations. Errors name the URL (password removed) and what failed.
  static StatusOr<std::unique_ptr<Store>> open(const std::string& url);
  virtual ~Store() = default;

  virtual std::string backend() const = 0;  ///< "sqlite" or "postgresql"
  virtual StatusOr<int> schemaVersion() = 0;

  /// Registers a robot or refreshes its last_seen / map_hash / radius.
  virtual Status upsertRobot(const RobotRecord& robot) = 0;
  virtual StatusOr<std::vector<RobotRecord>> robots() = 0;
  virtual StatusOr<std::optional<RobotRecord>> robot(const std::string& robot) = 0;

  /// Stores the message (and its telemetry row) in one transaction. Returns false, storing
  /// nothing, when (robot, seq) is stored already. (PostgreSQL: a call that lost its connection
  /// during COMMIT retries on a new one, and may then answer false for the message its first
  /// attempt stored; either way the message is stored, so the server acknowledges it.)
  StatusOr<bool> appendMessage(const RobotMessage& message) {
    ADIT_ASSIGN_OR_RETURN(std::size_t fresh, appendBatch(&message, 1));
    return fresh > 0;
  }
  /// Stores several messages in ONE transaction (one disk flush instead of one per message),
  /// each at most once per (robot, seq); returns how many were new. All or nothing: a message
  /// that fails its checks refuses the whole batch, and nothing of it is stored.
  /// Durability, both backends: once appendMessage/appendMessages returned, the messages
  /// survive a killed process and a power cut (SQLite: WAL + synchronous=FULL; PostgreSQL:
  /// synchronous_commit=on), so the server may acknowledge them.
  StatusOr<std::size_t> appendMessages(const std::vector<RobotMessage>& messages) {
    return appendBatch(messages.data(), messages.size());
  }
  /// Highest stored seq of the robot, 0 when none.
  virtual StatusOr<std::int64_t> lastSeq(const std::string& robot) = 0;
  /// Bytes of the robot's stored message bodies (its quota's measure): a scan of the robot's
  /// rows, so the server asks once per robot and counts on from there.
  virtual StatusOr<std::int64_t> storedBytes(const std::string& robot) = 0;
  /// Messages of `robot` with seq >= from_seq, in seq order, at most `limit`, and no more once
  /// their bodies reach `max_bytes` (the message that crosses it is the last; the bodies beyond
  /// are not read into memory).
  virtual StatusOr<std::vector<RobotMessage>> history(const std::string& robot, std::int64_t from_seq,
                                                      std::size_t limit, std::size_t max_bytes = kMaxHistoryBytes) = 0;
  /// The robot's newest message of `type` (telemetry, plan, obstacles, ...), if any; its cost
  /// depends on the rows stored, never on how far apart their seqs are. (A restarted server
  /// shows each robot's last state from these.)
  virtual StatusOr<std::optional<RobotMessage>> lastOfType(const std::string& robot, const std::string& type) = 0;
  virtual StatusOr<std::int64_t> telemetryRows() = 0;

  /// Stores a new command (status pending) and returns its id.
  virtual StatusOr<std::int64_t> addCommand(const Command& command) = 0;
  /// Commands only move forward: pending → sent → accepted → executed, or refused (with the
  /// reason) from any unanswered state; executed and refused are final. An update that would
  /// not move the command forward (a repeated or late answer) changes nothing and returns OK;
  /// compare with command() first to know whether it changed. NotFound for an unknown id.
  virtual Status updateCommand(std::int64_t command_id, CommandStatus status, const std::string& reason,
                               const std::string& updated_at) = 0;
  virtual StatusOr<std::optional<Command>> command(std::int64_t command_id) = 0;
  /// The robot's commands ("" = every robot's), newest last, at most `limit` (the newest).
  virtual StatusOr<std::vector<Command>> commands(const std::string& robot, std::size_t limit) = 0;
  /// Commands of the robot still pending or sent (to resend after its hello), oldest first.
  virtual StatusOr<std::vector<Command>> unansweredCommands(const std::string& robot) = 0;

  /// Stores a new alarm (not cleared, not acknowledged) and returns its id.
  virtual StatusOr<std::int64_t> addAlarm(const Alarm& alarm) = 0;
  /// Marks the alarm's condition over at `at`; an alarm cleared already keeps its first time.
  /// NotFound for an unknown id.
  virtual Status clearAlarm(std::int64_t alarm_id, const std::string& at) = 0;
  /// Records who acknowledged the alarm and when, once: a second acknowledgement is refused
  /// (FailedPrecondition naming who did it first and when) and changes nothing. NotFound for
  /// an unknown id. Returns the alarm as stored.
  virtual StatusOr<Alarm> acknowledgeAlarm(std::int64_t alarm_id, const std::string& operator_name,
                                           const std::string& at) = 0;
  virtual StatusOr<std::optional<Alarm>> alarm(std::int64_t alarm_id) = 0;
  /// The robot's alarms ("" = every robot's), oldest first, at most `limit` (the newest);
  /// `open_only`: those not both cleared and acknowledged.
  virtual StatusOr<std::vector<Alarm>> alarms(const std::string& robot, bool open_only, std::size_t limit) = 0;

 protected:
  /// The backends' one way to store: `count` messages in one transaction (see appendMessages).
  virtual StatusOr<std::size_t> appendBatch(const RobotMessage* messages, std::size_t count) = 0;
};

}  // namespace adit::console
