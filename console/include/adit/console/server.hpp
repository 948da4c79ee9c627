// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The virtual remote-control centre's server (issue 11; Guo 2022 §1): one port for the page,
/// the REST API and the two WebSocket streams (robots upload, viewers watch), exactly as
/// console/doc/protocol.md. Everything a robot sends is validated (size, types, finite numbers,
/// known robot) before the Store sees it; a refused message stores nothing and the server keeps
/// serving. Operator commands need the token, goals are checked against the served map's
/// distance field (free, clearance >= the robot's radius).
///
/// Boost.Beast, because it does HTTP and WebSocket on one port with one io_context (Debian's
/// libboost1.74-dev, header-only): cpp-httplib 0.11 has no WebSocket, and websocketpp's HTTP side
/// cannot serve a page with its assets. All I/O and every Store call run on the thread that
/// calls run(); stop() may be called from any thread.
///
///   ADIT_ASSIGN_OR_RETURN(auto server, Server::create(loaded, field, *store, options));
///   std::fprintf(stderr, "http://127.0.0.1:%u/\n", server->port());
///   server->run();  // until stop() or, with options.stop_on_signals, SIGINT / SIGTERM
///
/// The roadway surface the page draws (`GET /api/map/mesh`) is buildRoadwayMesh(): the boundary
/// between free and rock cells, coplanar faces merged into rectangles.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "adit/console/protocol_limits.hpp"
#include "adit/console/store.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/status.hpp"

namespace adit::console {

/// What one robot may send and keep (console/doc/protocol.md, "Quotas"). Rates are enforced by
/// reading the robot's connection no faster than they allow: a robot over its rate is slowed
/// (TCP pushes back, its link's outbox holds what it sends meanwhile), nothing it sent is lost.
/// Stored bytes are a hard limit: past it a message is refused with an error naming the quota,
/// so a robot (or a stolen credential) cannot fill the centre's disk.
struct RobotQuota {
  /// Sustained: a robot at 50 Hz sends about 60 messages a second with its plans; a live run
  /// at 40 times real time about 450.
  double messages_per_s = 1000.0;
  double burst_messages = 10000.0;  ///< an outbox's resend after a reconnection (10,000 by default)
  /// Sustained: an honest robot sends about 30 KB/s, with a full plan (about 180 KB) now and then.
  double bytes_per_s = 1.0 * (1 << 20);
  /// Small: what a burst writes at once delays every robot's messages behind it (8 MiB: 1.2 s at
  /// the 99th percentile under attack, 2 MiB: 90 ms). A resent outbox of 5 MB takes 3 s.
  double burst_bytes = 2.0 * (1 << 20);
  std::int64_t stored_bytes = std::int64_t{4} << 30;  ///< message bodies kept per robot: 57 h at 50 Hz

  Status validate() const;
};

struct ServerOptions {
  std::string address = "127.0.0.1";  ///< loopback unless told otherwise
  unsigned short port = 8080;         ///< 0: any free port (see Server::port())
  std::string token;                  ///< operator token, required
  std::string operator_name = "operator";  ///< who the token's commands are logged as
  std::string map_name;               ///< `name` in GET /api/map (the map file's name)
  std::string map_hash;               ///< "fnv1a64:..." a robot's hello must match
  std::string web_dir;                ///< console/web: index.html, console.js, console.css
  std::string three_dir = "/usr/share/javascript/three";  ///< Debian's libjs-three
  bool stop_on_signals = false;       ///< SIGINT / SIGTERM end run() cleanly
  /// Mesh cell edge [m]; 0 picks a multiple of the voxel size that keeps the surface small.
  double mesh_cell = 0.0;
  /// Origins (`scheme://host[:port]`) besides the console's own whose pages may open its
  /// WebSockets (`--allow-origin`); a browser's handshake from any other origin is refused 403.
  std::vector<std::string> allowed_origins;
  /// Robot credentials (`--robot-tokens FILE`): robot id -> token. A robot's connection
  /// authenticates with its own token and may then speak only as that robot; the operator token
  /// speaks for any robot (a single-robot setup, tests).
  std::map<std::string, std::string> robot_tokens;
  /// Bytes one viewer may have queued (kMaxViewerQueueBytes; at least 1 MiB). Tests lower it to
  /// reach the limit with less traffic.
  std::size_t viewer_queue_bytes = kMaxViewerQueueBytes;
  /// Per robot id (`--robot-rate`, `--robot-bandwidth`, `--robot-store-quota`).
  RobotQuota quota;
  /// A telemetry `min_clearance` below this raises a `clearance` alarm (`--alarm-clearance`) [m]:
  /// the global planner's default safety margin.
  double alarm_clearance_m = 0.2;
  /// Telemetry is stale after two periods, and never sooner than this (`--alarm-stale-min`) [s]:
  /// a robot at 50 Hz is not late after 40 ms of a busy network.
  double alarm_stale_min_s = 0.5;

  Status validate() const;
};

/// Parses `HOST:PORT` (`127.0.0.1:8080`, `0.0.0.0:0`, `[::1]:8080`) into the options.
Status parseListen(const std::string& listen, ServerOptions* options);

/// A robot-tokens file: one `ROBOT_ID TOKEN` per line, `#` comments and blank lines ignored.
/// Errors name `file` and the line: a bad robot id, a token shorter than kMinTokenLength or with
/// white space, an id or a token given twice.
StatusOr<std::map<std::string, std::string>> parseRobotTokens(const std::string& text, const std::string& file);

/// The roadway surface: a triangle list with one normal per vertex, pointing into free space.
struct RoadwayMesh {
  double cell = 0.0;                 ///< edge of the cells the surface was extracted at [m]
  std::vector<float> positions;      ///< x, y, z per vertex
  std::vector<float> normals;        ///< x, y, z per vertex
  std::vector<std::uint32_t> indices;  ///< three per triangle
  std::size_t quads() const { return indices.size() / 6; }
};

/// Extracts the free/rock boundary at `cell` (a multiple of the map's resolution; 0 chooses
/// one so that the free space is at most ~150,000 cells). A cell is free when the voxel at its
/// centre is free; outside the map is rock. Coplanar faces are merged greedily into rectangles.
StatusOr<RoadwayMesh> buildRoadwayMesh(const map::OccupancyMap& map, double cell = 0.0);

class Server {
 public:
  /// Binds the listening socket (so port() is known) and prepares the map's JSON and mesh.
  /// `loaded`, `field` and `store` must outlive the server.
  static StatusOr<std::unique_ptr<Server>> create(const map::LoadedMap& loaded, const map::DistanceField& field,
                                                  Store& store, ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  unsigned short port() const;
  /// Serves until stop() (or a signal with stop_on_signals). Returns the reason it stopped
  /// abnormally (a Store failure is logged and answered 500, never fatal).
  Status run();
  /// Thread-safe: closes the listener and every connection; run() returns.
  void stop();

 struct Impl;  ///< private to server.cpp (named here so its sessions can reach it)

 private:
  explicit Server(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace adit::console
