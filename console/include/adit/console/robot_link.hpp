// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// RobotLink: the robot's side of the operations console's live link (issue 11; the contract is
/// console/doc/protocol.md). A WebSocket client (Boost.Beast) to ws://HOST:PORT/ws/robot that
///
/// - says `hello` (robot id, map name, map hash, radius) on every connection and reads `welcome`;
/// - numbers every message it sends with the robot's `seq` (1, 2, 3, ... for the link's life,
///   never reused; a robot id the centre already holds messages of, from an earlier run, goes on
///   after the first welcome's acked_seq) and keeps it in an outbox until the centre's `ack`;
///   after a reconnect it
///   drops what `welcome.acked_seq` covers and resends the rest in order, so nothing is lost and
///   the centre, which stores each (robot, seq) once, duplicates nothing;
/// - reconnects with a backoff (0.1 s doubling to 2 s) whenever the connection drops;
/// - queues inbound `command`s for the robot's own thread (pollCommands()), and remembers the last
///   result it gave each command_id: a command the centre sends again (it resends every pending
///   command after each hello) is answered again with the stored result, never executed twice.
///
/// The outbox is bounded (LinkOptions::outbox_limit). When it is full, send() drops the oldest
/// unacknowledged telemetry (counted in stats().dropped_telemetry); plans, obstacles, events and
/// command results are never dropped: when only they fill the outbox, send() blocks the caller
/// (the simulation) until acknowledgements make room.
///
/// All network I/O runs on the link's own thread; send(), pollCommands(), answer() and flush()
/// may be called from any one other thread.
///
///   StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect("ws://127.0.0.1:8080", hello);
///   (*link)->send(telemetry);                      // a Telemetry (messages.hpp) or a JSON object text; robot and seq are filled in
///   for (const ReceivedCommand& c : (*link)->pollCommands()) (*link)->answer(c.id, "accepted", "", t);
///   (*link)->flush(5.0);                           // wait for the acks before exiting

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/console/messages.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::console {

/// What the robot says in `hello`.
struct RobotHello {
  std::string robot;     ///< 1-64 chars of [A-Za-z0-9_.-]
  std::string map;       ///< the map file's name, e.g. "district.yaml"
  std::string map_hash;  ///< map::fileContentHash() of the map file
  double radius_m = 0.4;
  Status validate() const;
};

struct LinkOptions {
  std::size_t outbox_limit = 10000;      ///< unacknowledged messages kept
  double connect_timeout_s = 5.0;        ///< the first connection (connect() fails after it)
  double max_backoff_s = 2.0;            ///< between reconnection attempts
  /// The robot's credential, sent as `Authorization: Bearer TOKEN` in the WebSocket handshake:
  /// its token from the centre's `--robot-tokens` file, or the operator token. Empty: none (a
  /// centre that checks refuses with 401, and connect() fails with its reason).
  std::string token;
};

/// An operator command as received (protocol.md, centre → robot). Fields not given for the kind
/// are empty.
struct ReceivedCommand {
  std::int64_t id = 0;
  std::string kind;  ///< pause | resume | goal | block | reopen | manual | release | estop | estop_release
  std::optional<map::Vec3> goal;
  std::optional<map::Vec3> velocity;
  std::string roadway;
  std::string operator_name;
};

/// Parses one `command` message; the error names the field (kinds outside the protocol, missing
/// or non-finite arguments are refused here, before the robot sees them).
StatusOr<ReceivedCommand> parseCommand(const std::string& json_text);

struct LinkStats {
  std::uint64_t sent = 0;               ///< frames written (resends included)
  std::uint64_t resent = 0;             ///< of them, resends after a reconnect
  std::uint64_t acked_seq = 0;          ///< the highest seq the centre acknowledged
  std::uint64_t last_seq = 0;           ///< the highest seq given out
  std::uint64_t connections = 0;        ///< successful hello/welcome exchanges
  std::uint64_t dropped_telemetry = 0;  ///< telemetry dropped because the outbox was full
  std::uint64_t duplicate_commands = 0; ///< commands received again and answered from the store
  std::size_t outbox = 0;               ///< unacknowledged now
  bool connected = false;
  std::string last_error;               ///< of the connection, for the log
};

class RobotLink {
 public:
  /// Connects to `url` (ws://HOST:PORT, optionally with the path; /ws/robot when none) and
  /// completes the hello/welcome exchange. Errors: a malformed URL or hello (invalidArgument), no
  /// server or a refusal such as a different map (unavailable, with the centre's reason), within
  /// options.connect_timeout_s.
  static StatusOr<std::unique_ptr<RobotLink>> connect(const std::string& url, const RobotHello& hello,
                                                      const LinkOptions& options = {});
  ~RobotLink();  ///< stops the I/O thread; what is unacknowledged is lost (call flush() first)
  RobotLink(const RobotLink&) = delete;
  RobotLink& operator=(const RobotLink&) = delete;

  /// Queues a message (a JSON object text with "type"; "robot" and "seq" are set here) and
  /// returns its seq. Refuses, before it takes a seq, what the centre would refuse: the centre's own
  /// parser reads it (not a JSON object, an unknown type, a missing or malformed field, a small
  /// message over 4 KiB; the message names it, e.g. "link: unknown status 'dancing'"). May block
  /// while the outbox is full of messages that are never dropped (see the file comment).
  StatusOr<std::uint64_t> send(const std::string& json_object);
  /// The protocol's typed messages (messages.hpp), sent as their toJson().
  StatusOr<std::uint64_t> send(const Telemetry& m) { return send(toJson(m)); }
  StatusOr<std::uint64_t> send(const Plan& m) { return send(toJson(m)); }
  StatusOr<std::uint64_t> send(const Obstacles& m) { return send(toJson(m)); }
  StatusOr<std::uint64_t> send(const Event& m) { return send(toJson(m)); }
  /// The commands received since the last call, each once: e-stops first, then the others in
  /// arrival order.
  std::vector<ReceivedCommand> pollCommands();
  /// Sends command_result for `command_id` and stores it as that command's answer.
  Status answer(std::int64_t command_id, const std::string& result, const std::string& reason, double t_s);
  /// Waits until every message sent so far is acknowledged; false after `timeout_s`.
  bool flush(double timeout_s);
  LinkStats stats() const;

 private:
  struct Impl;
  explicit RobotLink(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace adit::console
