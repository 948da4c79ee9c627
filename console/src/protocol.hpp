// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Validation of the console's JSON messages (console/doc/protocol.md): every check that decides
// whether a robot message or an operator command may be stored, kept apart from the I/O so the
// tests can reach each refusal directly. A refusal is an InvalidArgument status whose message is
// the `reason` sent back to the client.

#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include <nlohmann/json.hpp>

#include "adit/console/messages.hpp"
#include "adit/console/store.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::console::protocol {

using Json = nlohmann::json;

inline constexpr const char* kMalformedJson = "malformed JSON";
inline constexpr const char* kBadRobotId = "robot id must be 1-64 characters of [A-Za-z0-9_.-]";
/// 1–64 characters of [A-Za-z0-9_.-].
bool validRobotId(const std::string& id);

/// Parses one message: not JSON or not an object is an error.
StatusOr<Json> parseObject(const std::string& text);

struct Hello {
  std::string robot;
  std::string map;
  std::string map_hash;
  double radius = 0.0;
};
StatusOr<Hello> parseHello(const Json& j);

/// A robot → centre message's body as its type (messages.hpp).
using Body = std::variant<Telemetry, Plan, Obstacles, Event, CommandResult>;
/// "telemetry", "plan", "obstacles", "event" or "command_result".
const char* typeOf(const Body& body);

/// The one parser of a robot → centre message (robot and seq aside), used by both ends: the robot
/// link reads what it is asked to send with it before queueing, the centre what arrives. `type`, a
/// finite `t` and every field of the type: numbers finite, points [x, y, z], lists at most
/// kMaxPoints, statuses and results from their sets, names and labels at most 64 bytes.
StatusOr<Body> parseBody(const Json& j);

/// What the centre reads from a robot after hello: parseBody, plus robot and seq >= 1 in range.
/// `message` is the store's row (its `body` left to the caller: the text as received).
struct RobotFrame {
  RobotMessage message;
  Body body;
};
StatusOr<RobotFrame> parseRobotMessage(const Json& j);

/// A telemetry, event or command_result message over kMaxSmallMessageBytes is refused.
Status checkSize(const std::string& type, std::size_t bytes);

/// What only the centre knows: the message's points within `box` (the served map's bounds
/// inflated by kMapBoundsMargin), its speeds at most kMaxReportedSpeed and radii in
/// [0, kMaxReportedRadius]. A refusal names the field and the value.
Status checkWithin(const Body& body, const map::Aabb& box);

/// An operator command's arguments: its kind and what the kind needs. One parser for both ends:
/// the centre reads them from POST /api/commands (parseCommandRequest), the robot from the
/// centre's `command` (RobotLink's parseCommand); each then checks the ranges it knows (the
/// centre the map and the robot's radius, the robot its own limits).
struct CommandArgs {
  std::string kind;  ///< pause | resume | goal | block | reopen | manual | release | estop | estop_release
  std::optional<map::Vec3> goal;
  std::string roadway;
  std::optional<map::Vec3> velocity;
};
StatusOr<CommandArgs> parseCommandArgs(const Json& j);

/// An operator's POST /api/commands body.
struct CommandRequest : CommandArgs {
  std::string robot;
};
StatusOr<CommandRequest> parseCommandRequest(const Json& j);

/// The command as sent to the robot (protocol.md "centre → robot").
Json commandMessage(const Command& c);
/// The command's state as pushed to viewers and listed by GET /api/commands.
Json commandState(const Command& c);

/// Now, ISO 8601 UTC with milliseconds ("2026-11-30T23:59:59.123Z").
std::string isoNow();

}  // namespace adit::console::protocol
