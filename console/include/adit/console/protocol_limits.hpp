// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The numbers both ends of the console's protocol check (console/doc/protocol.md, "Limits"):
/// the server refuses a robot's message outside them, and the robot's link refuses a centre's
/// command or acknowledgement outside them. One definition, so the two ends cannot drift apart.

#include <cstddef>
#include <cstdint>

namespace adit::console {

/// Maximum size of one message (WebSocket frame or HTTP body).
inline constexpr std::size_t kMaxMessageBytes = 256 * 1024;
/// Size of one telemetry, event or command_result message: an honest one is under 500 bytes
/// (only plans and obstacles carry lists). A larger one is refused: it would be stored and
/// pushed to every viewer at the robot's rate.
inline constexpr std::size_t kMaxSmallMessageBytes = 4096;
/// Points in one path or obstacle list.
inline constexpr std::size_t kMaxPoints = 10000;
/// Messages a viewer may have waiting before the oldest telemetry is dropped.
inline constexpr std::size_t kMaxViewerQueue = 1024;
/// Bytes a viewer may have waiting (its snapshot included): past them the oldest telemetry is
/// dropped, and a viewer whose other messages alone exceed them is closed (1013, try again later).
inline constexpr std::size_t kMaxViewerQueueBytes = std::size_t{32} << 20;
/// Commands of one robot still pending or sent before POST /api/commands answers 429.
inline constexpr std::size_t kMaxPendingCommands = 64;
/// Fastest manual velocity set-point an operator may send (its norm) [m/s].
inline constexpr double kMaxManualSpeed = 2.0;
/// Largest seq (and acked_seq): 2^53 - 1, the largest integer every JSON reader (the page's
/// JavaScript included) holds exactly. A robot that reached it would need a new robot id; at
/// 50 messages a second that is 5.7 million years.
inline constexpr std::int64_t kMaxSeq = (std::int64_t{1} << 53) - 1;
/// How far beyond a robot's last stored seq a message may be: a robot sends in order, at most
/// its outbox (10,000 by default) ahead.
inline constexpr std::int64_t kMaxSeqGap = 1000000;
/// Largest absolute coordinate of a goal [m]: as a scenario's points.
inline constexpr double kMaxCoordinate = 1e7;
/// Bodies in one history answer (`GET /api/history`, Store::history): the answer ends after the
/// message that crosses it (so it always holds one), and a client pages on from the last seq.
/// Without it one answer of 10,000 messages of 256 KiB would be 2.5 GB in the server's memory.
inline constexpr std::size_t kMaxHistoryBytes = std::size_t{8} << 20;
/// Largest robot radius a hello may give [m]: a larger one would make every goal unreachable.
inline constexpr double kMaxRobotRadius = 10.0;
/// How far outside the served map's bounds a robot may place a point it reports (its pose, goal,
/// path, rock, tracks, an event's centre) [m]: localisation drifts a little past a surveyed
/// face, a point 10 m beyond it is not in this mine.
inline constexpr double kMapBoundsMargin = 10.0;
/// Fastest velocity a robot may report, its own or a tracked obstacle's (the norm) [m/s]: a mine
/// vehicle drives at most 10, a drone flies at most 20.
inline constexpr double kMaxReportedSpeed = 50.0;
/// Largest radius a robot may report for a tracked obstacle or an event [m].
inline constexpr double kMaxReportedRadius = 100.0;
/// Shortest robot token (`adit serve --robot-tokens`): as the operator token's 16 characters.
inline constexpr std::size_t kMinTokenLength = 16;
/// Longest telemetry period a robot may declare [s]: the stale-telemetry alarm waits two of
/// them, and an operator waiting more than two minutes for it is not watching the robot.
inline constexpr double kMaxTelemetryPeriod = 60.0;

}  // namespace adit::console
