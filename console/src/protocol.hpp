// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Validation of the console's JSON messages (console/doc/protocol.md): every check that decides
// whether a robot message or an operator command may be stored, kept apart from the I/O so the
// tests can reach each refusal directly. A refusal is an InvalidArgument status whose message is
// the `reason` sent back to the client.

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

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

/// A robot → centre message after hello (telemetry, plan, obstacles, event, command_result):
/// type, robot, seq >= 1, finite t and every type's fields, point lists <= kMaxPoints, every
/// number finite. `out.body` is left to the caller (the text as received).
StatusOr<RobotMessage> parseRobotMessage(const Json& j);

/// A telemetry, event or command_result message over kMaxSmallMessageBytes is refused.
Status checkSize(const std::string& type, std::size_t bytes);

/// The message's points within `box` (the served map's bounds inflated by kMapBoundsMargin), its
/// speeds at most kMaxReportedSpeed and radii in [0, kMaxReportedRadius] (after
/// parseRobotMessage accepted it): a refusal names the field and the value.
Status checkWithin(const Json& j, const map::Aabb& box);

/// command_result's fields (after parseRobotMessage accepted it).
struct CommandResult {
  std::int64_t command_id = 0;
  CommandStatus status = CommandStatus::kAccepted;
  std::string reason;
};
CommandResult commandResultOf(const Json& j);

/// An operator command's arguments: its kind and what the kind needs. One parser for both ends:
/// the centre reads them from POST /api/commands (parseCommandRequest), the robot from the
/// centre's `command` (RobotLink's parseCommand); each then checks the ranges it knows (the
/// centre the map and the robot's radius, the robot its own limits).
struct CommandArgs {
  std::string kind;  ///< pause | resume | goal | block | reopen | manual | release
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
