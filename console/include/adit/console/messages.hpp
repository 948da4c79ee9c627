// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The robot → centre messages of the console's protocol (console/doc/protocol.md) as types, for
/// any robot that links adit::console: fill one in and RobotLink::send() it. Their JSON is written
/// here once (toJson), so the simulator (`adit simulate --live`), a robot's own code and the tests
/// cannot drift from the protocol. `robot` and `seq` are the link's to fill in. Both ends read a
/// message back with the same parser (one per type): RobotLink::send() refuses what the centre would
/// refuse before it is queued, and the centre checks what arrives with it, then against what only
/// it knows (protocol_limits.hpp): points inside the map, speeds and radii in range, a clock that
/// never goes back.
///
///   Telemetry m;
///   m.t = t; m.pose = position; m.velocity = velocity; m.status = "following";
///   link->send(m);

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "adit/map/types.hpp"

namespace adit::console {

/// The robot's state, every telemetry period.
struct Telemetry {
  double t = 0.0;  ///< mission time [s]
  map::Vec3 pose = map::Vec3::Zero();
  map::Vec3 velocity = map::Vec3::Zero();
  /// following | yielding | detouring | stuck | replanning | no_route | paused | manual |
  /// arrived | collision | estop (held by an operator's e-stop until it is released)
  std::string status = "following";
  std::optional<map::Vec3> goal;
  std::optional<map::Vec3> subgoal;        ///< the local layer's current sub-goal, when steering
  /// Robot surface to rock [m] in the robot's believed map (0 when touching); none: the robot
  /// does not know. The centre raises a `clearance` alarm below its margin.
  std::optional<double> min_clearance;
  /// |velocity| [m/s], for the console's time-series; none: the reader takes |velocity|.
  std::optional<double> speed;
  /// The robot's telemetry period [s], so the centre knows when telemetry is stale (> 2
  /// periods); none: the centre estimates it from the arrivals.
  std::optional<double> period;
  /// The robot's heading about z [rad]; none: the viewer draws no heading.
  std::optional<double> yaw;
  /// A ground robot's body as a box: length along the heading, width, height [m], the pose its
  /// centre; none: the viewer draws the sphere of the hello's radius.
  std::optional<map::Vec3> body;
  /// The body's shape: "box" (none says the same) or "cylinder", a round robot, whose body is
  /// then [diameter, diameter, height]. Only with `body`.
  std::optional<std::string> body_shape;
};

/// The expected path, on every (re)plan.
struct Plan {
  double t = 0.0;
  std::string reason = "initial";  ///< initial | replan | goal | blocked
  std::vector<map::Vec3> path;
  std::vector<std::string> labels;  ///< labels[i] names path[i + 1]: the break points A, B, ...
};

struct TrackReport {
  std::string id;
  map::Vec3 position = map::Vec3::Zero();
  map::Vec3 velocity = map::Vec3::Zero();
  double radius = 0.0;  ///< [m], at most kMaxReportedRadius
};

/// Newly sensed rock (voxel centres) since the last Obstacles, and the moving obstacles tracked
/// now; at most kMaxPoints of each per message (splitObstacles() cuts a longer list).
struct Obstacles {
  double t = 0.0;
  std::vector<map::Vec3> rock;
  std::vector<TrackReport> tracks;
};

/// Something that happened in the mine, e.g. a roof fall.
struct Event {
  double t = 0.0;             ///< when it is sent (the clock never goes back)
  std::optional<double> at;   ///< when it happened, if earlier
  std::string kind;           ///< e.g. roof_fall
  std::optional<map::Vec3> center;
  std::optional<double> radius;
};

/// A robot's answer to an operator command (RobotLink::answer() sends it).
struct CommandResult {
  double t = 0.0;
  std::int64_t command_id = 0;       ///< 1 .. kMaxSeq
  std::string result = "accepted";   ///< accepted | refused | executed
  std::string reason;
};

/// Each message's JSON object text, without robot and seq.
std::string toJson(const Telemetry& m);
std::string toJson(const Plan& m);
std::string toJson(const Obstacles& m);
std::string toJson(const Event& m);
std::string toJson(const CommandResult& m);

/// `m` as messages of at most kMaxPoints rock points and tracks each, in order (the tracks go
/// with the first); one message when it fits.
std::vector<Obstacles> splitObstacles(const Obstacles& m);

}  // namespace adit::console
