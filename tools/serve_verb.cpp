// SPDX-License-Identifier: BSD-3-Clause
// `adit serve`: the operations console (issue 11). Loads the map and its distance field, opens
// the data exchange centre's database, and serves the page, the REST API and the robots' and
// viewers' WebSockets until SIGINT / SIGTERM.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "adit/console/server.hpp"
#include "adit/console/store.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/content_hash.hpp"
#include "adit/map/size_estimate.hpp"
#include "common/batch_runner.hpp"
#include "common/cli.hpp"
#include "common/plan_output.hpp"
#include "common/progress.hpp"
#include "verbs.hpp"

namespace adit::tools {
namespace {

struct ServeArgs {
  std::string map;
  std::string db = "sqlite:adit-centre.db";
  std::string listen = "127.0.0.1:8080";
  std::string token_file, robot_tokens;
  std::vector<std::string> allow_origins;
  double mesh_cell = 0.0;
  double robot_rate = console::RobotQuota{}.messages_per_s;
  std::string robot_bandwidth = "1M", robot_store_quota = "4G", viewer_queue = "32M";
  double alarm_clearance = console::ServerOptions{}.alarm_clearance_m;
  double alarm_stale_min = console::ServerOptions{}.alarm_stale_min_s;
  bool quiet = false;
  bool no_cache = false;
};

// 128 random bits as hex: the operator token when no file gives one.
StatusOr<std::string> randomToken() {
  std::ifstream in("/dev/urandom", std::ios::binary);
  unsigned char bytes[16];
  if (!in.read(reinterpret_cast<char*>(bytes), sizeof bytes)) return internalError("cannot read /dev/urandom");
  std::string hex;
  for (unsigned char b : bytes) {
    char two[3];
    std::snprintf(two, sizeof two, "%02x", b);
    hex += two;
  }
  return hex;
}

int runServe(const ServeArgs& args) {
  console::ServerOptions options;
  if (Status s = console::parseListen(args.listen, &options); !s.ok()) return report(s);
  options.stop_on_signals = true;
  options.mesh_cell = args.mesh_cell;
  options.alarm_clearance_m = args.alarm_clearance;
  options.alarm_stale_min_s = args.alarm_stale_min;
  if (!args.token_file.empty()) {
    StatusOr<TokenFile> t = readTokenFile(args.token_file);
    if (!t.ok()) return report(t.status());
    options.token = t->token;
    if (!t->label.empty()) options.operator_name = t->label;
  } else {
    StatusOr<std::string> token = randomToken();
    if (!token.ok()) return report(token.status());
    options.token = *token;
  }
  if (!args.robot_tokens.empty()) {
    StatusOr<std::string> text = map::readFile(args.robot_tokens, std::size_t{16} << 20);
    if (!text.ok()) return report(text.status());
    StatusOr<std::map<std::string, std::string>> tokens = console::parseRobotTokens(*text, args.robot_tokens);
    if (!tokens.ok()) return report(tokens.status());
    options.robot_tokens = std::move(*tokens);
  }
  options.allowed_origins = args.allow_origins;
  options.quota.messages_per_s = args.robot_rate;
  options.quota.burst_messages = 10.0 * args.robot_rate;
  StatusOr<std::uint64_t> bandwidth = map::parseByteSize(args.robot_bandwidth);
  if (!bandwidth.ok()) return report(invalidArgument("--robot-bandwidth: " + bandwidth.status().message()));
  options.quota.bytes_per_s = double(*bandwidth);
  options.quota.burst_bytes = std::max(2.0 * double(*bandwidth), double(console::kMaxMessageBytes));
  StatusOr<std::uint64_t> stored = map::parseByteSize(args.robot_store_quota);
  if (!stored.ok()) return report(invalidArgument("--robot-store-quota: " + stored.status().message()));
  if (*stored > std::uint64_t{1} << 50) return report(invalidArgument("--robot-store-quota: at most 1024T"));
  options.quota.stored_bytes = static_cast<std::int64_t>(*stored);
  StatusOr<std::uint64_t> viewer_queue = map::parseByteSize(args.viewer_queue);
  if (!viewer_queue.ok()) return report(invalidArgument("--viewer-queue: " + viewer_queue.status().message()));
  if (*viewer_queue > std::uint64_t{1} << 40) return report(invalidArgument("--viewer-queue: at most 1T"));
  options.viewer_queue_bytes = static_cast<std::size_t>(*viewer_queue);
  StatusOr<std::string> hash = map::fileContentHash(args.map);
  if (!hash.ok()) return report(hash.status());
  options.map_hash = *hash;
  options.map_name = args.map.substr(args.map.find_last_of('/') + 1);
  // Bad options are said before the map loads (which takes a while).
  if (Status s = options.validate(); !s.ok()) return report(s);

  StatusOr<map::World> world = loadWorld(args.map, map::UnknownPolicy::kRock, args.quiet, args.no_cache);
  if (!world.ok()) return report(world.status());
  StatusOr<std::unique_ptr<console::Store>> store = console::Store::open(args.db);
  if (!store.ok()) return report(store.status());
  StatusOr<std::unique_ptr<console::Server>> server =
      console::Server::create(world->loaded(), world->field(), **store, options);
  if (!server.ok()) return report(server.status());
  const bool any = options.address == "0.0.0.0" || options.address == "::";
  const std::string host = options.address.find(':') != std::string::npos ? "[" + options.address + "]" : options.address;
  std::fprintf(stderr, "adit serve: %s (%s), database %s\n", args.map.c_str(), options.map_hash.c_str(),
               (*store)->backend().c_str());
  std::fprintf(stderr, "adit serve: http://%s:%u/\n", any ? "127.0.0.1" : host.c_str(), (*server)->port());
  std::fprintf(stderr, "adit serve: operator token (%s): %s\n", options.operator_name.c_str(), options.token.c_str());
  if (!options.robot_tokens.empty())
    std::fprintf(stderr, "adit serve: %zu robot credentials from %s\n", options.robot_tokens.size(), args.robot_tokens.c_str());
  if (any) std::fprintf(stderr, "adit serve: warning: listening on every interface, not only loopback\n");
  std::fflush(stderr);
  if (Status s = (*server)->run(); !s.ok()) return report(s);
  std::fprintf(stderr, "adit serve: stopped\n");
  return kExitOk;
}

}  // namespace

void registerServeVerb(CLI::App& app, int* rc) {
  auto args = std::make_shared<ServeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "serve",
      "Operations console: serve the page, the REST API and the robots' and viewers' WebSockets\n"
      "(protocol: console/doc/protocol.md) until SIGINT/SIGTERM. Prints the URL and the operator\n"
      "token on stderr.");
  cmd->add_option("--map", args->map, "Map (survey .yaml, .bt or .ot) the robots share")->required();
  cmd->add_option("--db", args->db, "Database: sqlite:PATH or postgresql://user@host:port/db")->capture_default_str();
  cmd->add_option("--listen", args->listen, "HOST:PORT to listen on (port 0: any free one)")->capture_default_str();
  cmd->add_option("--token-file", args->token_file,
                  "File whose first line is the operator token, TOKEN or LABEL:TOKEN (default: a random one)");
  cmd->add_option("--robot-tokens", args->robot_tokens,
                  "File of robot credentials, one 'ROBOT_ID TOKEN' per line: a robot then connects with its own "
                  "token and speaks only as that robot (without it, robots use the operator token)");
  cmd->add_option("--allow-origin", args->allow_origins,
                  "SCHEME://HOST[:PORT] of another site whose pages may open the WebSockets (repeatable; default: "
                  "the console's own pages only)");
  cmd->add_option("--mesh-cell", args->mesh_cell, "Cell edge of the page's roadway surface [m] (0: automatic)")
      ->capture_default_str();
  cmd->add_option("--robot-rate", args->robot_rate,
                  "Messages a second one robot may send, sustained (bursts of 10x that): a faster robot is read "
                  "more slowly, nothing is lost")
      ->capture_default_str();
  cmd->add_option("--robot-bandwidth", args->robot_bandwidth,
                  "Bytes a second one robot may send, sustained (bursts of 2x that; K, M, G suffixes)")
      ->capture_default_str();
  cmd->add_option("--robot-store-quota", args->robot_store_quota,
                  "Message bytes the database keeps per robot; past it the robot's new messages are refused "
                  "(K, M, G suffixes)")
      ->capture_default_str();
  cmd->add_option("--viewer-queue", args->viewer_queue,
                  "Bytes queued for one viewer, its snapshot included (K, M, G suffixes): a viewer too slow for "
                  "what cannot be dropped is closed (1013)")
      ->capture_default_str();
  cmd->add_option("--alarm-clearance", args->alarm_clearance,
                  "A robot's reported clearance to rock below this raises a 'clearance' alarm [m]")
      ->capture_default_str();
  cmd->add_option("--alarm-stale-min", args->alarm_stale_min,
                  "Telemetry is stale after two of the robot's periods and never sooner than this [s]")
      ->capture_default_str();
  cmd->add_flag("--no-cache", args->no_cache, "Build the map's octree and distance field afresh: neither read nor write the map cache");
  cmd->add_flag("-q,--quiet", args->quiet, "No progress bar");
  cmd->callback([args, rc] { *rc = runServe(*args); });
}

}  // namespace adit::tools
