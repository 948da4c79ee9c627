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
/// Points in one path or obstacle list.
inline constexpr std::size_t kMaxPoints = 10000;
/// Messages a viewer may have waiting before the oldest telemetry is dropped.
inline constexpr std::size_t kMaxViewerQueue = 1024;
/// Commands of one robot still pending or sent before POST /api/commands answers 429.
inline constexpr std::size_t kMaxPendingCommands = 64;
/// Fastest manual velocity set-point an operator may send (its norm) [m/s].
inline constexpr double kMaxManualSpeed = 2.0;
/// Largest seq (and acked_seq): 2^53 - 1, the largest integer every JSON reader (the page's
/// JavaScript included) holds exactly. A robot that reached it would need a new robot id; at
/// 50 messages a second that is 5.7 million years.
inline constexpr std::int64_t kMaxSeq = (std::int64_t{1} << 53) - 1;
/// Largest absolute coordinate of a goal [m]: as a scenario's points.
inline constexpr double kMaxCoordinate = 1e7;

}  // namespace adit::console
