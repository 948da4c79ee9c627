// SPDX-License-Identifier: BSD-3-Clause
// The console's server against a real SQLite store in a temp dir (or the PostgreSQL fixture's),
// on a free loopback port; Beast clients act as robots, viewers and operators (protocol.md). The
// ServerTest suite runs twice: against the Server in-process (where the sanitizers and a debugger
// reach it), and with ADIT_TEST_SERVE=<adit> against the real `adit serve`, the same options given
// as its flags (tests/console/server.cmake registers both).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <fcntl.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include "adit/console/robot_link.hpp"
#include "adit/console/server.hpp"
#include "adit/console/store.hpp"
#include "adit/map/content_hash.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "console/beast_client.hpp"
#include "protocol.hpp"  // the console's private parser, for the round trip
#include "support/synthetic_roadway.hpp"

namespace adit::console {
namespace {

using namespace adit::console::testing;  // NOLINT: Beast's names and the client helpers

constexpr const char* kHash = "fnv1a64:00000000c0ffee00";  // any well-formed hash, for option checks
std::string g_map_hash;  // tests/console/data/junction.yaml's, as `adit serve` computes it
constexpr const char* kToken = "0123456789abcdef0123456789abcdef";
constexpr const char* kRobotToken = "robot-r-own-0123456789";
constexpr std::size_t kViewerQueueBytes = std::size_t{4} << 20;  // the fixture's, to reach the limit sooner

// ----- the roadway mesh -----------------------------------------------------------------------

TEST(RoadwayMesh, IsAClosedSurfaceAroundTheFreeSpace) {
  const map::OccupancyMap m = test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(3.0, 2.4), 10.0));
  StatusOr<RoadwayMesh> mesh = buildRoadwayMesh(m, 0.4);
  ASSERT_TRUE(mesh.ok()) << mesh.status().toString();
  EXPECT_NEAR(mesh->cell, 0.4, 1e-12);
  ASSERT_GT(mesh->quads(), 0u);
  // Closed: the vector area of the whole surface is zero; and the box of the vertices is the
  // roadway's (10 m x 3 m x 2.4 m, within a cell).
  Eigen::Vector3d area = Eigen::Vector3d::Zero();
  map::Aabb box;
  for (std::size_t t = 0; t < mesh->indices.size(); t += 3) {
    Eigen::Vector3d p[3];
    for (int k = 0; k < 3; ++k) {
      const std::size_t v = mesh->indices[t + static_cast<std::size_t>(k)];
      p[k] = {mesh->positions[3 * v], mesh->positions[3 * v + 1], mesh->positions[3 * v + 2]};
      box.min = box.min.cwiseMin(p[k]);
      box.max = box.max.cwiseMax(p[k]);
    }
    const Eigen::Vector3d a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]);
    area += a;
    // Wound counter-clockwise seen from the free side: the face normal is the stored one.
    const std::size_t v0 = mesh->indices[t];
    const Eigen::Vector3d n(mesh->normals[3 * v0], mesh->normals[3 * v0 + 1], mesh->normals[3 * v0 + 2]);
    EXPECT_GT(a.dot(n), 0.0);
  }
  EXPECT_LT(area.norm(), 1e-3);
  const map::Vec3 size = box.max - box.min;
  EXPECT_NEAR(size.x(), 10.0, 0.81);
  EXPECT_NEAR(size.y(), 3.0, 0.81);
  EXPECT_NEAR(size.z(), 2.4, 0.81);
  // Merged: far fewer rectangles than the cell faces of a 25 x 7 x 6 box (2 * (175 + 150 + 42)).
  EXPECT_LT(mesh->quads(), 100u);
}

TEST(RoadwayMesh, AutomaticCellIsAMultipleOfTheVoxel) {
  const map::OccupancyMap m = test::voxelizeOrFail(test::junctionNetwork());
  StatusOr<RoadwayMesh> mesh = buildRoadwayMesh(m);
  ASSERT_TRUE(mesh.ok());
  const double k = mesh->cell / 0.2;
  EXPECT_NEAR(k, std::round(k), 1e-9);
  EXPECT_GT(mesh->quads(), 10u);
  EXPECT_FALSE(buildRoadwayMesh(m, -1.0).ok());
}

TEST(ServerOptions, ListenAndValidation) {
  ServerOptions o;
  EXPECT_TRUE(parseListen("0.0.0.0:0", &o).ok());
  EXPECT_EQ(o.address, "0.0.0.0");
  EXPECT_EQ(o.port, 0);
  EXPECT_TRUE(parseListen("[::1]:8081", &o).ok());
  EXPECT_EQ(o.address, "::1");
  EXPECT_EQ(o.port, 8081);
  for (const char* bad : {"8080", "localhost:8080", "127.0.0.1:99999", "127.0.0.1:", "127.0.0.1:-1", ":80"})
    EXPECT_FALSE(parseListen(bad, &o).ok()) << bad;
  o.map_hash = kHash;
  EXPECT_FALSE(o.validate().ok());  // no token
  o.token = "with space";
  EXPECT_FALSE(o.validate().ok());
  o.token = kToken;
  EXPECT_TRUE(o.validate().ok());
  o.viewer_queue_bytes = 1000;  // a viewer's snapshot alone would not fit
  EXPECT_FALSE(o.validate().ok());
}

// ----- the server -------------------------------------------------------------------------------

struct Reply {
  int status = 0;
  std::string body;
  Json json() const { return Json::parse(body, nullptr, false); }
};

class WsClient {
 public:
  WsClient(unsigned short port, const std::string& path, const std::string& token = kToken)
      : ws_(openWebSocket(ioc_, "127.0.0.1", std::to_string(port), path, token)) {}
  void send(const std::string& text) { ws_.write(net::buffer(text)); }
  void send(const Json& j) { send(j.dump()); }
  /// The next message, skipping the centre's alarms and e-stop states: they concern every viewer
  /// and arrive whenever another test's robot goes quiet or hangs up.
  Json recv() {
    for (;;) {
      Json j = readJson(ws_);
      const std::string type = j.value("type", "");
      if (type != "alarm" && type != "estop") return j;
    }
  }
  /// The next message, whatever it is.
  Json recvAny() { return readJson(ws_); }
  /// The next message of `type`, skipping others (at most `limit`).
  Json recvType(const std::string& type, int limit = 1000) {
    for (int i = 0; i < limit; ++i) {
      Json j = readJson(ws_);
      if (j.value("type", "") == type) return j;
    }
    return nullptr;
  }
  /// Reads until the server closes; the close code (-1: the connection broke otherwise).
  int closeCode() {
    beast::error_code ec;
    while (!ec) {
      beast::flat_buffer b;
      ws_.read(b, ec);
    }
    return ec == websocket::error::closed ? static_cast<int>(ws_.reason().code) : -1;
  }
  /// Sends hello and returns the welcome's acked_seq.
  std::int64_t hello(const std::string& robot, double radius = 0.4) {
    send(Json{{"type", "hello"}, {"robot", robot}, {"map", "junction.yaml"}, {"map_hash", g_map_hash}, {"radius", radius}});
    const Json w = recv();
    EXPECT_EQ(w.value("type", ""), "welcome") << w.dump();
    return w.value("acked_seq", std::int64_t{-1});
  }

 private:
  net::io_context ioc_;
  websocket::stream<tcp::socket> ws_;
};

Json telemetry(const std::string& robot, std::int64_t seq, double x = 5.0) {
  return {{"type", "telemetry"}, {"robot", robot}, {"seq", seq}, {"t", 0.1 * static_cast<double>(seq)},
          {"pose", {x, 0.0, 1.0}}, {"velocity", {0.5, 0.0, 0.0}}, {"status", "following"},
          {"goal", {12.0, 0.0, 1.0}}, {"subgoal", nullptr}, {"min_clearance", 1.2}};
}

std::string junctionYaml() { return std::string(ADIT_CONSOLE_TEST_DATA) + "/junction.yaml"; }

/// A running centre on a free loopback port: the console's Server on a thread of this process or,
/// when ADIT_TEST_SERVE names the adit binary, `adit serve` as a child process with the same
/// options as its flags. Options the flags cannot say (a burst other than the CLI's 10x / 2x) fail
/// the test, so both kinds of centre are given the same thing.
class Centre {
 public:
  Centre(const map::LoadedMap& loaded, const map::DistanceField& field, const std::string& db_url,
         const ServerOptions& o, const std::filesystem::path& log) {
    if (const char* adit = std::getenv("ADIT_TEST_SERVE")) {
      spawn(adit, db_url, o, log);
      return;
    }
    StatusOr<std::unique_ptr<Store>> store = Store::open(db_url);
    EXPECT_TRUE(store.ok()) << store.status().toString();
    if (!store.ok()) return;
    store_ = std::move(*store);
    StatusOr<std::unique_ptr<Server>> server = Server::create(loaded, field, *store_, o);
    EXPECT_TRUE(server.ok()) << server.status().toString();
    if (!server.ok()) return;
    server_ = std::move(*server);
    port_ = server_->port();
    thread_ = std::thread([this] { (void)server_->run(); });
  }
  ~Centre() {
    if (server_) {
      server_->stop();
      thread_.join();
    }
    if (pid_ > 0) stopChild();
  }
  Centre(const Centre&) = delete;
  Centre& operator=(const Centre&) = delete;
  bool ok() const { return port_ != 0; }
  unsigned short port() const { return port_; }

 private:
  static std::string number(double v) {
    std::ostringstream out;
    out.precision(17);
    out << v;
    return out.str();
  }

  void spawn(const std::string& adit, const std::string& db_url, const ServerOptions& o,
             const std::filesystem::path& log) {
    EXPECT_DOUBLE_EQ(o.quota.burst_messages, 10.0 * o.quota.messages_per_s) << "adit serve bursts 10x --robot-rate";
    EXPECT_DOUBLE_EQ(o.quota.burst_bytes, std::max(2.0 * o.quota.bytes_per_s, double(kMaxMessageBytes)))
        << "adit serve bursts 2x --robot-bandwidth";
    log_ = log;
    const std::filesystem::path token_file = log.string() + ".token", robot_file = log.string() + ".robots";
    std::ofstream(token_file) << (o.operator_name.empty() ? "" : o.operator_name + ":") << o.token << "\n";
    std::vector<std::string> args = {adit, "serve", "-q", "--map", junctionYaml(), "--db", db_url,
                                     "--listen", "127.0.0.1:0", "--token-file", token_file.string(),
                                     "--viewer-queue", std::to_string(o.viewer_queue_bytes),
                                     "--robot-rate", number(o.quota.messages_per_s),
                                     "--robot-bandwidth", std::to_string(std::uint64_t(o.quota.bytes_per_s)),
                                     "--robot-store-quota", std::to_string(o.quota.stored_bytes),
                                     "--alarm-clearance", number(o.alarm_clearance_m),
                                     "--alarm-stale-min", number(o.alarm_stale_min_s)};
    for (const std::string& origin : o.allowed_origins) args.insert(args.end(), {"--allow-origin", origin});
    if (!o.robot_tokens.empty()) {
      std::ofstream robots(robot_file);
      for (const auto& [robot, token] : o.robot_tokens) robots << robot << " " << token << "\n";
      args.insert(args.end(), {"--robot-tokens", robot_file.string()});
    }
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = posix_spawn(&pid_, adit.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (err != 0) {
      ADD_FAILURE() << "cannot start " << adit << ": " << std::strerror(err);
      pid_ = -1;
      return;
    }
    // The port it took, from the line it prints when it listens (the map loads first).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    const std::string marker = "adit serve: http://127.0.0.1:";
    while (std::chrono::steady_clock::now() < deadline) {
      std::ifstream in(log);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (auto at = text.find(marker); at != std::string::npos && text.find('/', at + marker.size()) != std::string::npos) {
        port_ = static_cast<unsigned short>(std::stoi(text.substr(at + marker.size())));
        return;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        ADD_FAILURE() << "adit serve exited before listening:\n" << text;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "adit serve did not listen within 120 s (log " << log << ")";
  }

  // SIGTERM, as an operator stops it: it must finish cleanly, exit 0, within a bound.
  void stopChild() {
    ::kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        ADD_FAILURE() << "adit serve did not stop within 60 s of SIGTERM (log " << log_ << ")";
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "adit serve ended with status " << status
                                                                << " (log " << log_ << ")";
  }

  std::unique_ptr<Store> store_;
  std::unique_ptr<Server> server_;
  std::thread thread_;
  pid_t pid_ = -1;
  std::filesystem::path log_;
  unsigned short port_ = 0;
};

class ServerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                     ("adit_server_test_" + std::to_string(::getpid())));
    std::filesystem::remove_all(*dir_);
    std::filesystem::create_directories(*dir_);
    StatusOr<map::LoadedMap> loaded = map::loadMapAndSurvey(junctionYaml());
    ASSERT_TRUE(loaded.ok()) << loaded.status().toString();
    loaded_ = new map::LoadedMap(std::move(*loaded));
    StatusOr<map::DistanceField> f = map::DistanceField::build(loaded_->map);
    ASSERT_TRUE(f.ok());
    field_ = new map::DistanceField(std::move(*f));
    StatusOr<std::string> hash = map::fileContentHash(junctionYaml());
    ASSERT_TRUE(hash.ok());
    g_map_hash = *hash;
    startServer();
  }
  static void TearDownTestSuite() {
    stopServer();
    delete field_;
    delete loaded_;
    std::filesystem::remove_all(*dir_);
    delete dir_;
  }
  /// What every test's centre is given; a test's own centre starts from it.
  static ServerOptions options() {
    ServerOptions o;
    o.port = 0;
    o.token = kToken;
    o.operator_name = "alice";
    o.map_name = "junction.yaml";
    o.map_hash = g_map_hash;
    return o;
  }
  /// A centre with `o` on the fixture's database, its log under the fixture's directory.
  static std::unique_ptr<Centre> startCentre(const ServerOptions& o) {
    static int n = 0;
    return std::make_unique<Centre>(*loaded_, *field_, databaseUrl(), o, *dir_ / ("serve-" + std::to_string(++n) + ".log"));
  }
  static void startServer() {
    ServerOptions o = options();
    o.allowed_origins = {"https://ops.example"};
    o.robot_tokens = {{"r-own", kRobotToken}};
    o.viewer_queue_bytes = kViewerQueueBytes;
    // The fixture's tests send megabytes in bursts to reach other limits; the quotas have their
    // own centres below.
    o.quota.bytes_per_s = 256.0 * (1 << 20);
    o.quota.burst_bytes = 2.0 * o.quota.bytes_per_s;
    centre_ = startCentre(o).release();
    ASSERT_TRUE(centre_->ok());
  }
  static void stopServer() {
    delete centre_;
    centre_ = nullptr;
  }
  static unsigned short port() { return centre_->port(); }
  // SQLite in the temp dir; PostgreSQL when CTest's fixture started a throw-away server
  // (tests/console/postgres_fixture.sh writes its URL into ADIT_TEST_POSTGRES_STATE/url). Every
  // test uses its own robot ids, so the tests share that one fresh database.
  static std::string databaseUrl() {
    if (const char* state = std::getenv("ADIT_TEST_POSTGRES_STATE")) {
      std::ifstream in(std::filesystem::path(state) / "url");
      std::string url;
      std::getline(in, url);
      return url;
    }
    return "sqlite:" + (*dir_ / "centre.db").string();
  }
  static std::string backend() { return std::getenv("ADIT_TEST_POSTGRES_STATE") ? "postgresql" : "sqlite"; }

  static Reply request(http::verb verb, const std::string& target, const std::string& body = "",
                       const std::string& token = "") {
    net::io_context ioc;
    tcp::socket s(ioc);
    s.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port()));
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1");
    if (!token.empty()) req.set(http::field::authorization, "Bearer " + token);
    req.body() = body;
    req.prepare_payload();
    http::write(s, req);
    beast::flat_buffer b;
    http::response_parser<http::string_body> p;
    p.body_limit(64 << 20);
    p.skip(verb == http::verb::head);  // a HEAD answer announces a length but has no body
    http::read(s, b, p);
    return {static_cast<int>(p.get().result_int()), p.get().body()};
  }
  static Reply get(const std::string& target, const std::string& token = kToken) {
    return request(http::verb::get, target, "", token);
  }
  static Reply post(const Json& body, const std::string& token = kToken) {
    return request(http::verb::post, "/api/commands", body.dump(), token);
  }
  static std::size_t stored(const std::string& robot) {
    const Reply r = get("/api/history?robot=" + robot);
    return r.status == 200 ? r.json().size() : 0;
  }
  static void expectHealthy() {
    const Reply h = get("/api/health");
    ASSERT_EQ(h.status, 200);
    EXPECT_EQ(h.json()["ok"], true);
    EXPECT_EQ(h.json()["db"], backend());
    EXPECT_EQ(h.json()["schema_version"], kSchemaVersion);
  }

  static std::filesystem::path* dir_;
  static map::LoadedMap* loaded_;
  static map::DistanceField* field_;
  static Centre* centre_;
};
std::filesystem::path* ServerTest::dir_ = nullptr;
map::LoadedMap* ServerTest::loaded_ = nullptr;
map::DistanceField* ServerTest::field_ = nullptr;
Centre* ServerTest::centre_ = nullptr;

TEST_F(ServerTest, ServesThePageItsAssetsAndTheMap) {
  expectHealthy();
  const Reply page = get("/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("console.js"), std::string::npos);
  for (const char* asset : {"/assets/console.js", "/assets/console.css", "/assets/three.min.js", "/assets/OrbitControls.js"})
    EXPECT_EQ(get(asset).status, 200) << asset;
  EXPECT_NE(get("/assets/three.min.js").body.find("REVISION"), std::string::npos);
  const Json m = get("/api/map").json();
  EXPECT_EQ(m["hash"], g_map_hash);
  EXPECT_DOUBLE_EQ(m["resolution"].get<double>(), 0.2);
  ASSERT_EQ(m["roadways"].size(), 3u);
  EXPECT_EQ(m["roadways"][0]["name"], "main");
  EXPECT_DOUBLE_EQ(m["roadways"][0]["width"].get<double>(), 4.0);
  EXPECT_EQ(m["roadways"][0]["centreline"].size(), 3u);
  const Json mesh = get("/api/map/mesh").json();
  EXPECT_GT(mesh["indices"].size(), 0u);
  EXPECT_EQ(mesh["positions"].size(), mesh["normals"].size());
  const Reply head = request(http::verb::head, "/api/map", "", kToken);
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.body.empty());
  EXPECT_EQ(get("/nope").status, 404);
  EXPECT_EQ(get("/api/nope").status, 404);
  EXPECT_EQ(request(http::verb::delete_, "/api/map").status, 405);
  EXPECT_EQ(request(http::verb::post, "/api/robots", "{}").status, 405);
}

TEST_F(ServerTest, StoresEachSeqOnceAndAcknowledgesResends) {
  {
    WsClient robot(port(), "/ws/robot");
    EXPECT_EQ(robot.hello("r-ack"), 0);
    for (int seq = 1; seq <= 3; ++seq) {
      robot.send(telemetry("r-ack", seq));
      EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", seq}}));
    }
    robot.send(telemetry("r-ack", 2, 9.0));  // a resend after a lost ack: acked, not stored again
    EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", 2}}));
  }
  WsClient again(port(), "/ws/robot");
  EXPECT_EQ(again.hello("r-ack"), 3);
  const Json history = get("/api/history?robot=r-ack").json();
  ASSERT_EQ(history.size(), 3u);
  EXPECT_EQ(history[1]["pose"][0], 5.0);  // the first copy of seq 2
  EXPECT_TRUE(history[0].contains("received_at"));
  EXPECT_EQ(get("/api/history?robot=r-ack&from_seq=2&limit=1").json().size(), 1u);
  EXPECT_EQ(get("/api/history?robot=r-ack&limit=10001").status, 400);
  EXPECT_EQ(get("/api/history?robot=r-ack&from_seq=x").status, 400);
  EXPECT_EQ(get("/api/history?robot=nobody").status, 404);
  EXPECT_EQ(get("/api/history").status, 400);
  const Json robots = get("/api/robots").json();
  bool found = false;
  for (const Json& r : robots)
    if (r["robot"] == "r-ack") {
      found = true;
      EXPECT_EQ(r["last_seq"], 3);
      EXPECT_EQ(r["telemetry"]["seq"], 3);
    }
  EXPECT_TRUE(found);
}

TEST_F(ServerTest, RefusesEveryBadRobotMessageAndStoresNothing) {
  WsClient robot(port(), "/ws/robot");
  robot.send(telemetry("r-bad", 1));  // before hello
  EXPECT_EQ(robot.recv()["reason"], "send hello first");
  EXPECT_EQ(robot.hello("r-bad"), 0);
  auto without = [](Json j, const char* key) {
    j.erase(key);
    return j;
  };
  auto with = [](Json j, const char* key, Json v) {
    j[key] = std::move(v);
    return j;
  };
  const Json t = telemetry("r-bad", 1);
  const Json plan = {{"type", "plan"}, {"robot", "r-bad"}, {"seq", 1}, {"t", 1.0}, {"reason", "initial"},
                     {"path", {{0, 0, 1}, {6, 0, 1}, {12, 0, 1}}}, {"labels", {"A", "B"}}};
  const Json obstacles = {{"type", "obstacles"}, {"robot", "r-bad"}, {"seq", 1}, {"t", 1.0},
                          {"rock", {{1, 1, 1}}},
                          {"tracks", {{{"id", "v1"}, {"position", {3, 0, 1}}, {"velocity", {0, 0, 0}}, {"radius", 1.0}}}}};
  const Json event = {{"type", "event"}, {"robot", "r-bad"}, {"seq", 1}, {"t", 1.0}, {"kind", "roof_fall"},
                      {"center", {5, 0, 1}}, {"radius", 1.5}};
  const Json result = {{"type", "command_result"}, {"robot", "r-bad"}, {"seq", 1}, {"t", 1.0}, {"command_id", 999999},
                       {"result", "accepted"}};
  Json too_long = plan;
  too_long["path"] = Json::array();
  for (int i = 0; i < 10001; ++i) too_long["path"].push_back({0.0, 0.0, 1.0});
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"unknown type", with(t, "type", "gossip").dump()},
      {"missing seq", without(t, "seq").dump()},
      {"seq 0", with(t, "seq", 0).dump()},
      // Beyond 2^53 - 1 (the protocol's range: what every JSON reader, the page's included, holds
      // exactly); 2^63 - 1 used to be stored and then broke the robot id for good.
      {"seq 2^53", with(t, "seq", std::int64_t{1} << 53).dump()},
      {"seq 2^63 - 1", with(t, "seq", std::numeric_limits<std::int64_t>::max()).dump()},
      {"seq as string", with(t, "seq", "1").dump()},
      {"missing t", without(t, "t").dump()},
      {"missing pose", without(t, "pose").dump()},
      {"pose of 2", with(t, "pose", {1, 2}).dump()},
      {"pose with a string", with(t, "pose", {1, "2", 3}).dump()},
      {"infinite x", R"({"type":"telemetry","robot":"r-bad","seq":1,"t":0.1,"pose":[1e999,0,1],"velocity":[0,0,0],"status":"following"})"},
      {"infinite t", R"({"type":"telemetry","robot":"r-bad","seq":1,"t":-1e400,"pose":[1,0,1],"velocity":[0,0,0],"status":"following"})"},
      {"unknown status", with(t, "status", "dancing").dump()},
      {"other robot", with(t, "robot", "r-other").dump()},
      {"bad robot id", with(t, "robot", "r bad").dump()},
      {"plan without path", without(plan, "path").dump()},
      {"plan labels not strings", with(plan, "labels", {1, 2}).dump()},
      {"plan of 10001 points", too_long.dump()},
      {"obstacles rock not points", with(obstacles, "rock", {1, 2, 3}).dump()},
      {"track without position", with(obstacles, "tracks", {{{"id", "v1"}}}).dump()},
      {"track id a number", with(obstacles, "tracks", {{{"id", 7}, {"position", {3, 0, 1}}}}).dump()},
      {"track id of 65 characters", with(obstacles, "tracks", {{{"id", std::string(65, 'v')}, {"position", {3, 0, 1}}}}).dump()},
      {"plan label of 65 characters", with(plan, "labels", {std::string(65, 'L')}).dump()},
      {"event at not a number", with(event, "at", "noon").dump()},
      {"event without kind", without(event, "kind").dump()},
      {"event radius string", with(event, "radius", "big").dump()},
      {"result unknown command", result.dump()},
      {"result unknown word", with(result, "result", "maybe").dump()},
      {"result without command", without(result, "command_id").dump()},
      {"hello without radius", R"({"type":"hello","robot":"r-bad","map_hash":"fnv1a64:00000000c0ffee00"})"},
      {"hello negative radius", R"({"type":"hello","robot":"r-bad","map_hash":"fnv1a64:00000000c0ffee00","radius":-1})"},
      {"not an object", "[1,2,3]"},
  };
  for (const auto& [what, text] : bad) {
    robot.send(text);
    const Json e = robot.recv();
    EXPECT_EQ(e.value("type", ""), "error") << what << ": " << e.dump();
    EXPECT_FALSE(e.value("reason", "").empty()) << what;
  }
  EXPECT_EQ(stored("r-bad"), 0u);
  EXPECT_EQ(get("/api/history?robot=r-other").status, 404);
  // The connection is still open and usable: a good message is stored.
  robot.send(plan);
  EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", 1}}));
  EXPECT_EQ(stored("r-bad"), 1u);
  expectHealthy();
}

TEST_F(ServerTest, ClosesOnGarbageOversizeAndAnotherMap) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.send(std::string("{\"type\": \"hel"));
    EXPECT_EQ(robot.recv()["reason"], "malformed JSON");
    EXPECT_EQ(robot.closeCode(), 1007);
  }
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-big");
    Json t = telemetry("r-big", 1);
    t["padding"] = std::string(kMaxMessageBytes, 'x');
    robot.send(t);
    EXPECT_EQ(robot.closeCode(), 1009);
  }
  EXPECT_EQ(stored("r-big"), 0u);
  {
    WsClient robot(port(), "/ws/robot");
    robot.send(Json{{"type", "hello"}, {"robot", "r-map"}, {"map_hash", "fnv1a64:ffffffffffffffff"}, {"radius", 0.4}});
    EXPECT_EQ(robot.recv()["type"], "error");
    EXPECT_EQ(robot.closeCode(), 1008);
  }
  EXPECT_EQ(get("/api/history?robot=r-map").status, 404);
  EXPECT_EQ(request(http::verb::post, "/api/commands", std::string(kMaxMessageBytes + 1, ' '), kToken).status, 413);
  expectHealthy();
}

TEST_F(ServerTest, OperatorCommandsAreCheckedStoredDeliveredAndTracked) {
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-cmd", 0.5);
  WsClient viewer(port(), "/ws/view");
  EXPECT_EQ(viewer.recv()["type"], "snapshot");

  const map::Vec3 free_goal(10.0, 0.0, 1.4), rock_goal(8.0, 5.0, 1.0), off_map(100.0, 0.0, 1.0), tight(7.0, 1.75, 1.0);
  ASSERT_TRUE(field_->isFree(free_goal));
  ASSERT_GE(field_->distance(free_goal), 0.5);
  ASSERT_FALSE(field_->isFree(rock_goal));
  ASSERT_TRUE(field_->isFree(tight));
  ASSERT_LT(field_->distance(tight), 0.5);
  auto goal = [](const map::Vec3& g) { return Json{{"robot", "r-cmd"}, {"kind", "goal"}, {"goal", {g.x(), g.y(), g.z()}}}; };

  EXPECT_EQ(post(goal(free_goal), "").status, 401);
  EXPECT_EQ(post(goal(free_goal), "wrong-token-wrong-token-wrong-to").status, 401);
  EXPECT_EQ(request(http::verb::post, "/api/commands", "{\"robot\":", kToken).status, 400);
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "dance"}}).status, 400);
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "goal"}}).status, 400);
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "goal"}, {"goal", {1, "2", 3}}}).status, 400);
  EXPECT_EQ(request(http::verb::post, "/api/commands", R"({"robot":"r-cmd","kind":"goal","goal":[1e999,0,1]})", kToken).status,
            400);
  EXPECT_EQ(post({{"robot", "nobody"}, {"kind", "pause"}}).status, 404);
  const Reply in_rock = post(goal(rock_goal));
  EXPECT_EQ(in_rock.status, 422);
  EXPECT_NE(in_rock.json()["error"].get<std::string>().find("in rock"), std::string::npos);
  const Reply outside = post(goal(off_map));
  EXPECT_EQ(outside.status, 422);
  EXPECT_NE(outside.json()["error"].get<std::string>().find("outside the map"), std::string::npos);
  const Reply too_close = post(goal(tight));
  EXPECT_EQ(too_close.status, 422);
  EXPECT_NE(too_close.json()["error"].get<std::string>().find("radius"), std::string::npos);
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "block"}, {"roadway", "nowhere"}}).status, 422);
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "manual"}, {"velocity", {2.5, 0, 0}}}).status, 422);
  EXPECT_TRUE(get("/api/commands?robot=r-cmd").json().empty());  // nothing of the refusals stored

  const Reply ok = post(goal(free_goal));
  ASSERT_EQ(ok.status, 202) << ok.body;
  const std::int64_t id = ok.json()["command_id"];
  EXPECT_EQ(ok.json()["status"], "pending");
  const Json delivered = robot.recv();
  EXPECT_EQ(delivered["type"], "command");
  EXPECT_EQ(delivered["command_id"], id);
  EXPECT_EQ(delivered["kind"], "goal");
  EXPECT_EQ(delivered["operator"], "alice");
  EXPECT_EQ(delivered["goal"], Json({10.0, 0.0, 1.4}));
  robot.send(Json{{"type", "command_result"}, {"robot", "r-cmd"}, {"seq", 1}, {"t", 2.0}, {"command_id", id},
                  {"result", "accepted"}});
  EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", 1}}));
  // The viewer saw pending, sent, the robot's message, accepted.
  std::vector<std::string> seen;
  for (int i = 0; i < 4; ++i) {
    const Json v = viewer.recv();
    seen.push_back(v["type"].get<std::string>() + (v.contains("status") && v["type"] == "command" ? ":" + v["status"].get<std::string>() : ""));
  }
  EXPECT_EQ(seen, (std::vector<std::string>{"command:pending", "command:sent", "command_result", "command:accepted"}));
  robot.send(Json{{"type", "command_result"}, {"robot", "r-cmd"}, {"seq", 2}, {"t", 3.0}, {"command_id", id},
                  {"result", "executed"}});
  EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", 2}}));
  robot.send(Json{{"type", "command_result"}, {"robot", "r-cmd"}, {"seq", 3}, {"t", 4.0}, {"command_id", id},
                  {"result", "accepted"}});  // a repeat of an earlier answer does not step back
  EXPECT_EQ(robot.recv(), (Json{{"type", "ack"}, {"seq", 3}}));
  const Json log = get("/api/commands?robot=r-cmd").json();
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0]["status"], "executed");
  EXPECT_EQ(log[0]["operator"], "alice");
  EXPECT_EQ(post({{"robot", "r-cmd"}, {"kind", "block"}, {"roadway", "crosscut"}}).status, 202);
  EXPECT_EQ(robot.recv()["roadway"], "crosscut");
}

// ----- e-stop --------------------------------------------------------------------------------

TEST_F(ServerTest, AnEstopGoesFirstIsAcknowledgedByTheRobotAndShownUntilReleased) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-estop");
  }
  // A robot away with a full queue: the e-stop is not held back by the pending limit.
  for (std::size_t i = 0; i < kMaxPendingCommands; ++i) ASSERT_EQ(post({{"robot", "r-estop"}, {"kind", "pause"}}).status, 202);
  ASSERT_EQ(post({{"robot", "r-estop"}, {"kind", "pause"}}).status, 429);
  const Reply stop = post({{"robot", "r-estop"}, {"kind", "estop"}});
  ASSERT_EQ(stop.status, 202) << stop.body;
  const std::int64_t id = stop.json()["command_id"];
  auto estopOf = [](const std::string& robot) {
    for (const Json& r : get("/api/robots").json())
      if (r["robot"] == robot) return r["estop"];
    return Json("no such robot");
  };
  EXPECT_EQ(estopOf("r-estop")["status"], "pending");
  EXPECT_EQ(estopOf("r-estop")["engaged"], false);
  EXPECT_EQ(estopOf("r-estop")["operator"], "alice");
  // While it is in force nothing that would move the robot is sent.
  for (const char* kind : {"resume", "release"}) {
    const Reply refused = post({{"robot", "r-estop"}, {"kind", kind}});
    EXPECT_EQ(refused.status, 409) << kind;
    EXPECT_NE(refused.json()["error"].get<std::string>().find("e-stopped"), std::string::npos) << refused.body;
  }
  EXPECT_EQ(post({{"robot", "r-estop"}, {"kind", "goal"}, {"goal", {10.0, 0.0, 1.4}}}).status, 409);

  WsClient viewer(port(), "/ws/view");
  const Json snap = viewer.recvAny();
  ASSERT_EQ(snap["type"], "snapshot");
  for (const Json& r : snap["robots"]) {
    if (r["robot"] == "r-estop") {
      EXPECT_EQ(r["estop"]["command_id"], id);
    }
  }
  // At its hello the robot gets the e-stop before the 64 commands issued ahead of it.
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-estop");
  const Json first = robot.recv();
  EXPECT_EQ(first["kind"], "estop");
  EXPECT_EQ(first["command_id"], id);
  EXPECT_EQ(first["operator"], "alice");
  for (std::size_t i = 0; i < kMaxPendingCommands; ++i) EXPECT_EQ(robot.recv()["kind"], "pause");
  EXPECT_EQ(viewer.recvType("estop")["estop"]["status"], "sent");

  robot.send(Json{{"type", "command_result"}, {"robot", "r-estop"}, {"seq", 1}, {"t", 1.0}, {"command_id", id},
                  {"result", "accepted"}});
  EXPECT_EQ(robot.recv()["type"], "ack");
  robot.send(Json{{"type", "command_result"}, {"robot", "r-estop"}, {"seq", 2}, {"t", 1.0}, {"command_id", id},
                  {"result", "executed"}, {"reason", "stopped"}});
  EXPECT_EQ(robot.recv()["type"], "ack");
  Json engaged;
  for (int i = 0; i < 4 && !(engaged.is_object() && engaged["estop"]["engaged"] == true); ++i) engaged = viewer.recvType("estop");
  EXPECT_EQ(engaged["robot"], "r-estop");
  EXPECT_EQ(engaged["estop"]["engaged"], true);
  EXPECT_EQ(estopOf("r-estop")["status"], "executed");
  // A robot held by its e-stop says so.
  Json held = telemetry("r-estop", 3);
  held["status"] = "estop";
  held["t"] = 1.5;
  robot.send(held);
  EXPECT_EQ(robot.recv()["type"], "ack");

  // Released only once the robot has executed the release.
  const Reply release = post({{"robot", "r-estop"}, {"kind", "estop_release"}});
  ASSERT_EQ(release.status, 202) << release.body;
  const std::int64_t rid = release.json()["command_id"];
  const Json delivered = robot.recv();
  EXPECT_EQ(delivered["kind"], "estop_release");
  EXPECT_TRUE(estopOf("r-estop").is_object());
  robot.send(Json{{"type", "command_result"}, {"robot", "r-estop"}, {"seq", 4}, {"t", 2.0}, {"command_id", rid},
                  {"result", "executed"}});
  EXPECT_EQ(robot.recv()["type"], "ack");
  Json released = viewer.recvType("estop");
  for (int i = 0; i < 4 && !released["estop"].is_null(); ++i) released = viewer.recvType("estop");
  EXPECT_TRUE(released["estop"].is_null()) << released.dump();
  EXPECT_TRUE(estopOf("r-estop").is_null());
  EXPECT_EQ(post({{"robot", "r-estop"}, {"kind", "estop_release"}}).status, 409);  // nothing to release
  // The log says who did what, as for any command.
  const Json log = get("/api/commands?robot=r-estop").json();
  EXPECT_EQ(log[log.size() - 2]["kind"], "estop");
  EXPECT_EQ(log[log.size() - 2]["status"], "executed");
  EXPECT_EQ(log.back()["kind"], "estop_release");
  EXPECT_EQ(log.back()["operator"], "alice");
}

// Its own centre and database: an e-stop for all reaches every robot the database knows.
TEST_F(ServerTest, AnEstopForAllStopsEveryKnownRobotAndSurvivesARestart) {
  const std::string url = "sqlite:" + (*dir_ / "estop_all.db").string();
  auto own = [&] {
    static int n = 0;
    return std::make_unique<Centre>(*loaded_, *field_, url, options(), *dir_ / ("estop-all-" + std::to_string(++n) + ".log"));
  };
  auto centre = own();
  ASSERT_TRUE(centre->ok());
  auto at = [&](http::verb verb, const std::string& target, const std::string& body = "") {
    net::io_context ioc;
    tcp::socket s(ioc);
    s.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), centre->port()));
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1");
    req.set(http::field::authorization, std::string("Bearer ") + kToken);
    req.body() = body;
    req.prepare_payload();
    http::write(s, req);
    beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(s, b, res);
    return Reply{static_cast<int>(res.result_int()), res.body()};
  };
  WsClient a(centre->port(), "/ws/robot"), b(centre->port(), "/ws/robot");
  a.hello("all-a");
  b.hello("all-b");
  EXPECT_EQ(request(http::verb::post, "/api/estop-all", "{}", "").status, 401);
  const Reply all = at(http::verb::post, "/api/estop-all", "{}");
  ASSERT_EQ(all.status, 202) << all.body;
  ASSERT_EQ(all.json()["commands"].size(), 2u);
  EXPECT_EQ(a.recv()["kind"], "estop");
  EXPECT_EQ(b.recv()["kind"], "estop");
  centre.reset();
  centre = own();  // restarted on the same database: the e-stops are still in force
  ASSERT_TRUE(centre->ok());
  for (const Json& r : at(http::verb::get, "/api/robots").json()) {
    EXPECT_TRUE(r["estop"].is_object()) << r.dump();
    EXPECT_EQ(r["estop"]["status"], "sent");
  }
  EXPECT_EQ(at(http::verb::post, "/api/commands", R"({"robot":"all-a","kind":"resume"})").status, 409);
}

// ----- alarms --------------------------------------------------------------------------------

TEST_F(ServerTest, AlarmsAreRaisedAcknowledgedWithWhoAndWhenClearedAndStored) {
  WsClient viewer(port(), "/ws/view");
  ASSERT_EQ(viewer.recvAny()["type"], "snapshot");
  auto nextAlarm = [&](const std::string& robot, const std::string& kind) {
    for (int i = 0; i < 1000; ++i) {
      const Json j = viewer.recvType("alarm");
      if (j.is_null() || (j["robot"] == robot && j["kind"] == kind)) return j;
    }
    return Json();
  };
  auto robot = std::make_unique<WsClient>(port(), "/ws/robot");
  robot->hello("r-alarm");
  // Clearance below the margin (0.2 m): major; a collision: critical.
  Json low = telemetry("r-alarm", 1);
  low["min_clearance"] = 0.05;
  robot->send(low);
  EXPECT_EQ(robot->recv()["type"], "ack");
  const Json clearance = nextAlarm("r-alarm", "clearance");
  EXPECT_EQ(clearance["severity"], "major");
  EXPECT_EQ(clearance["open"], true);
  EXPECT_TRUE(clearance["acked_at"].is_null());
  EXPECT_NE(clearance["message"].get<std::string>().find("0.05 m below the margin 0.20 m"), std::string::npos);
  Json hit = telemetry("r-alarm", 2);
  hit["status"] = "collision";
  hit["min_clearance"] = 0.0;
  robot->send(hit);
  EXPECT_EQ(robot->recv()["type"], "ack");
  const Json collision = nextAlarm("r-alarm", "collision");
  EXPECT_EQ(collision["severity"], "critical");
  // Still low: no second clearance alarm while the first stands.
  const Json listed = get("/api/alarms?robot=r-alarm").json();
  ASSERT_EQ(listed.size(), 2u) << listed.dump();

  // The operator acknowledges: who and when, once.
  const std::int64_t cid = clearance["alarm_id"];
  auto ack = [](const Json& body, const std::string& token = kToken) {
    return request(http::verb::post, "/api/alarms/ack", body.dump(), token);
  };
  EXPECT_EQ(ack({{"alarm_id", cid}}, "").status, 401);
  EXPECT_EQ(ack({{"alarm_id", "7"}}).status, 400);
  EXPECT_EQ(request(http::verb::post, "/api/alarms/ack", "{", kToken).status, 400);
  EXPECT_EQ(ack({{"alarm_id", 1 << 30}}).status, 404);
  const Reply acked = ack({{"alarm_id", cid}});
  ASSERT_EQ(acked.status, 200) << acked.body;
  EXPECT_EQ(acked.json()["acked_by"], "alice");
  const std::string when = acked.json()["acked_at"];
  EXPECT_EQ(when.size(), 24u) << when;  // 2026-12-03T10:00:00.000Z
  EXPECT_EQ(nextAlarm("r-alarm", "clearance")["acked_by"], "alice");
  const Reply twice = ack({{"alarm_id", cid}});
  EXPECT_EQ(twice.status, 409);
  EXPECT_NE(twice.json()["error"].get<std::string>().find("acknowledged by alice at " + when), std::string::npos) << twice.body;

  // The conditions end: both cleared; the acknowledged one is closed, the other still open.
  robot->send(telemetry("r-alarm", 3));
  EXPECT_EQ(robot->recv()["type"], "ack");
  // (A stale alarm may come and go meanwhile on a busy machine: the robot is silent while the
  // test talks to the centre.)
  auto openAlarms = [] {
    Json out = Json::array();
    for (const Json& a : get("/api/alarms?robot=r-alarm&open=1").json())
      if (a["kind"] != "stale_telemetry") out.push_back(a);
    return out;
  };
  Json open_list = openAlarms();
  for (int i = 0; i < 200 && open_list.size() != 1u; ++i) {  // cleared after 1 s without the condition
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    open_list = openAlarms();
  }
  ASSERT_EQ(open_list.size(), 1u) << open_list.dump();
  EXPECT_EQ(open_list[0]["kind"], "collision");
  EXPECT_FALSE(open_list[0]["cleared_at"].is_null());
  EXPECT_EQ(get("/api/alarms?open=2").status, 400);

  // Stale: a robot that declared a 0.05 s period and then says nothing for longer than the
  // threshold (two periods, at least 0.5 s).
  Json periodic = telemetry("r-alarm", 4);
  periodic["period"] = 0.05;
  robot->send(periodic);
  EXPECT_EQ(robot->recv()["type"], "ack");
  const Json stale = nextAlarm("r-alarm", "stale_telemetry");
  EXPECT_EQ(stale["severity"], "minor");
  EXPECT_NE(stale["message"].get<std::string>().find("threshold 0.50 s"), std::string::npos) << stale.dump();
  // Talking again, for longer than the 1 s an alarm's condition must stay ended: cleared.
  for (int seq = 5; seq < 20; ++seq) {
    robot->send(telemetry("r-alarm", seq));
    EXPECT_EQ(robot->recv()["type"], "ack");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_FALSE(nextAlarm("r-alarm", "stale_telemetry")["cleared_at"].is_null());

  // A lost link: critical, cleared by the robot's next hello.
  robot.reset();
  const Json lost = nextAlarm("r-alarm", "lost_link");
  EXPECT_EQ(lost["severity"], "critical");
  robot = std::make_unique<WsClient>(port(), "/ws/robot");
  robot->hello("r-alarm");
  EXPECT_FALSE(nextAlarm("r-alarm", "lost_link")["cleared_at"].is_null());

  // Stored: another connection to the database reads who acknowledged what, and when.
  StatusOr<std::unique_ptr<Store>> db = Store::open(databaseUrl());
  ASSERT_TRUE(db.ok()) << db.status().toString();
  StatusOr<std::optional<Alarm>> stored = (*db)->alarm(cid);
  ASSERT_TRUE(stored.ok() && stored->has_value());
  EXPECT_EQ((*stored)->acked_by, "alice");
  EXPECT_EQ((*stored)->acked_at, when);
  EXPECT_EQ((*stored)->kind, "clearance");
  EXPECT_FALSE((*stored)->cleared_at.empty());
}

// A hostile robot flapping between collision and following at its message rate raises one
// alarm, not one a message: an alarm clears only after its condition stays ended for 1 s.
TEST_F(ServerTest, AFlappingConditionIsOneAlarm) {
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-flap");
  for (int seq = 1; seq <= 40; ++seq) {
    Json m = telemetry("r-flap", seq);
    m["status"] = seq % 2 ? "collision" : "following";
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
  }
  const Json alarms = get("/api/alarms?robot=r-flap").json();
  ASSERT_EQ(alarms.size(), 1u) << alarms.dump();
  EXPECT_EQ(alarms[0]["kind"], "collision");
}

// A robot that reported `arrived` has ended its mission: its silence and its hang-up raise nothing.
TEST_F(ServerTest, ARobotThatArrivedHangsUpWithoutAnAlarm) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-done");
    robot.send(telemetry("r-done", 1));
    EXPECT_EQ(robot.recv()["type"], "ack");
    Json done = telemetry("r-done", 2);
    done["status"] = "arrived";
    robot.send(done);
    EXPECT_EQ(robot.recv()["type"], "ack");
    // Silent past the stale threshold (0.5 s), then gone.
    std::this_thread::sleep_for(std::chrono::milliseconds(800));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_TRUE(get("/api/alarms?robot=r-done").json().empty()) << get("/api/alarms?robot=r-done").body;
}

TEST_F(ServerTest, CommandsWaitForTheRobotsNextHelloAndAreBounded) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-away");
  }
  const Reply first = post({{"robot", "r-away"}, {"kind", "pause"}});
  ASSERT_EQ(first.status, 202);
  for (std::size_t i = 1; i < kMaxPendingCommands; ++i) ASSERT_EQ(post({{"robot", "r-away"}, {"kind", "resume"}}).status, 202);
  EXPECT_EQ(post({{"robot", "r-away"}, {"kind", "resume"}}).status, 429);
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-away");
  const Json c = robot.recv();
  EXPECT_EQ(c["type"], "command");
  EXPECT_EQ(c["command_id"], first.json()["command_id"]);
  EXPECT_EQ(c["kind"], "pause");
}

TEST_F(ServerTest, ViewersGetASnapshotThenEveryStoredMessage) {
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-view");
  robot.send(telemetry("r-view", 1, 3.0));
  robot.recv();
  WsClient viewer(port(), "/ws/view");
  const Json snap = viewer.recv();
  ASSERT_EQ(snap["type"], "snapshot");
  bool found = false;
  for (const Json& r : snap["robots"])
    if (r["robot"] == "r-view") {
      found = true;
      EXPECT_EQ(r["telemetry"]["pose"][0], 3.0);
    }
  EXPECT_TRUE(found);
  robot.send(telemetry("r-view", 2, 4.0));
  robot.recv();
  robot.send(telemetry("r-view", 2, 4.0));  // a resend is not pushed twice
  robot.recv();
  robot.send(telemetry("r-view", 3, 4.5));
  robot.recv();
  const Json a = viewer.recv(), b = viewer.recv();
  EXPECT_EQ(a["seq"], 2);
  EXPECT_EQ(b["seq"], 3);
  EXPECT_TRUE(a.contains("received_at"));
  viewer.send(std::string("{}"));
  EXPECT_EQ(viewer.recv()["type"], "error");
}

TEST_F(ServerTest, ASlowViewersQueueIsBoundedAndReportsWhatItDropped) {
  // A viewer with a tiny receive window that reads nothing while a robot sends a burst.
  net::io_context ioc;
  websocket::stream<tcp::socket> viewer(ioc);
  viewer.next_layer().open(tcp::v4());
  viewer.next_layer().set_option(net::socket_base::receive_buffer_size(4096));
  viewer.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port()));
  viewer.handshake("127.0.0.1", std::string("/ws/view?token=") + kToken);  // as the page does
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-lag");
  // 3.7 KB each (under the 4 KiB a telemetry may have): 15 MB in all, more than the loopback
  // socket buffers and the fixture's 4 MiB queue can hide.
  const int n = 4000, chunk = 500;
  const std::string padding(3500, 'p');
  for (int seq = 1; seq <= n; seq += chunk) {  // a robot reads its acks as it goes
    for (int k = seq; k < seq + chunk; ++k) {
      Json t = telemetry("r-lag", k, 1.0 + 1e-3 * k);
      t["padding"] = padding;
      robot.send(t);
    }
    for (int k = seq; k < seq + chunk; ++k) ASSERT_EQ(robot.recv()["type"], "ack");
  }
  // Every telemetry message is either delivered or counted in a `lag`; the newest always arrives.
  std::int64_t delivered = 0, dropped = 0, last = 0;
  while (last < n) {
    const Json m = readJson(viewer);
    if (m["type"] == "lag") dropped += m["dropped"].get<std::int64_t>();
    if (m["type"] == "telemetry" && m["robot"] == "r-lag") {
      ++delivered;
      EXPECT_GT(m["seq"].get<std::int64_t>(), last);
      last = m["seq"];
    }
  }
  EXPECT_GT(dropped, 0);
  EXPECT_EQ(delivered + dropped, n);
  EXPECT_EQ(stored("r-lag"), 1000u);  // the history's default page: everything was stored
  EXPECT_EQ(get("/api/history?robot=r-lag&from_seq=3001&limit=10000").json().size(), 1000u);
}

// ----- who may connect (issue 17): credentials and origins ------------------------------------

// The HTTP status of a WebSocket upgrade of `path` with these headers (101: accepted) and the
// refusal's body.
std::pair<int, std::string> upgrade(unsigned short port, const std::string& path,
                                    const std::vector<std::pair<http::field, std::string>>& headers) {
  net::io_context ioc;
  tcp::socket s(ioc);
  s.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  http::request<http::empty_body> req{http::verb::get, path, 11};
  req.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  req.set(http::field::upgrade, "websocket");
  req.set(http::field::connection, "Upgrade");
  req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
  req.set(http::field::sec_websocket_version, "13");
  for (const auto& [field, value] : headers) req.set(field, value);
  http::write(s, req);
  beast::flat_buffer b;
  http::response_parser<http::string_body> p;
  http::read(s, b, p);
  return {static_cast<int>(p.get().result_int()), p.get().body()};
}

TEST_F(ServerTest, AWebSocketFromAForeignOriginIsRefusedOnBothRoutes) {
  const std::string bearer = std::string("Bearer ") + kToken;
  for (const char* path : {"/ws/robot", "/ws/view"}) {
    SCOPED_TRACE(path);
    // The issue's attack: a page on another site opening the console's sockets with the
    // operator's browser. Refused before any WebSocket exists, whatever the credential.
    const auto evil = upgrade(port(), path, {{http::field::origin, "http://evil.example"}, {http::field::authorization, bearer}});
    EXPECT_EQ(evil.first, 403);
    EXPECT_NE(evil.second.find("origin 'http://evil.example' may not open"), std::string::npos) << evil.second;
    // The console's own page, an --allow-origin site, and a robot (no Origin) are let in.
    const std::string own = "http://127.0.0.1:" + std::to_string(port());
    EXPECT_EQ(upgrade(port(), path, {{http::field::origin, own}, {http::field::authorization, bearer}}).first, 101);
    EXPECT_EQ(upgrade(port(), path, {{http::field::origin, "https://ops.example"}, {http::field::authorization, bearer}}).first,
              101);
    EXPECT_EQ(upgrade(port(), path, {{http::field::authorization, bearer}}).first, 101);
    // A look-alike is not the allowed origin.
    EXPECT_EQ(upgrade(port(), path, {{http::field::origin, "https://ops.example.evil"}, {http::field::authorization, bearer}})
                  .first,
              403);
  }
}

TEST_F(ServerTest, EveryWebSocketAndEveryReadNeedsACredential) {
  for (const char* path : {"/ws/robot", "/ws/view"}) {
    SCOPED_TRACE(path);
    EXPECT_EQ(upgrade(port(), path, {}).first, 401);
    EXPECT_EQ(upgrade(port(), path, {{http::field::authorization, "Bearer not-the-token-0000000"}}).first, 401);
    EXPECT_EQ(upgrade(port(), std::string(path) + "?token=" + kToken, {}).first, 101);  // a browser's way
  }
  // A robot's own token opens /ws/robot, never /ws/view (it is not the operator).
  EXPECT_EQ(upgrade(port(), "/ws/robot", {{http::field::authorization, std::string("Bearer ") + kRobotToken}}).first, 101);
  EXPECT_EQ(upgrade(port(), "/ws/view", {{http::field::authorization, std::string("Bearer ") + kRobotToken}}).first, 401);
  // Reading the mine needs the operator token; the health check stays open for monitoring.
  for (const char* target : {"/api/robots", "/api/map", "/api/map/mesh", "/api/history?robot=r1", "/api/commands"}) {
    SCOPED_TRACE(target);
    EXPECT_EQ(get(target, "").status, 401);
    EXPECT_EQ(get(target, kRobotToken).status, 401);
  }
  EXPECT_EQ(get("/api/health", "").status, 200);
}

TEST_F(ServerTest, ARobotTokenSpeaksOnlyForItsRobot) {
  {
    WsClient own(port(), "/ws/robot", kRobotToken);
    EXPECT_EQ(own.hello("r-own"), 0);
    own.send(telemetry("r-own", 1));
    EXPECT_EQ(own.recv()["type"], "ack");
  }
  // The issue's impostor: r-own's credential saying hello as another robot is refused and
  // dropped; nothing is stored for the other robot.
  WsClient impostor(port(), "/ws/robot", kRobotToken);
  impostor.send(Json{{"type", "hello"}, {"robot", "r-victim"}, {"map", "junction.yaml"}, {"map_hash", g_map_hash}, {"radius", 0.4}});
  const Json e = impostor.recv();
  EXPECT_EQ(e["type"], "error");
  EXPECT_NE(e.value("reason", "").find("credential is robot 'r-own'"), std::string::npos) << e.dump();
  EXPECT_EQ(impostor.closeCode(), static_cast<int>(websocket::close_code::policy_error));
  EXPECT_EQ(get("/api/history?robot=r-victim").status, 404);
}

TEST_F(ServerTest, TheRobotLinkAuthenticatesAndSaysWhyTheCentreRefusedIt) {
  const std::string url = "ws://127.0.0.1:" + std::to_string(port());
  RobotHello hello;
  hello.robot = "r-own";
  hello.map = "junction.yaml";
  hello.map_hash = g_map_hash;
  LinkOptions options;
  options.connect_timeout_s = 10.0;
  // No credential: refused at once with the centre's reason (not retried until the timeout).
  const auto t0 = std::chrono::steady_clock::now();
  StatusOr<std::unique_ptr<RobotLink>> none = RobotLink::connect(url, hello, options);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("refused the connection (401): missing credential for /ws/robot"),
            std::string::npos)
      << none.status().message();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  // Its own token: connected. Another robot's id with it: refused by the hello.
  options.token = kRobotToken;
  StatusOr<std::unique_ptr<RobotLink>> own = RobotLink::connect(url, hello, options);
  ASSERT_TRUE(own.ok()) << own.status().message();
  own->reset();  // disconnects
  hello.robot = "r-someone-else";
  StatusOr<std::unique_ptr<RobotLink>> other = RobotLink::connect(url, hello, options);
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.status().message().find("credential is robot 'r-own'"), std::string::npos) << other.status().message();
}

TEST(Messages, ObstaclesAreSplitAtTheProtocolsListLimitWithTheTracksFirst) {
  Obstacles m;
  m.t = 2.5;
  for (int i = 0; i < 25000; ++i) m.rock.push_back({0.2 * (i % 100), 0.0, 1.0});
  m.tracks.push_back({"v1", {3, 0, 1}, {0.5, 0, 0}, 1.0});
  const std::vector<Obstacles> parts = splitObstacles(m);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].rock.size(), kMaxPoints);
  EXPECT_EQ(parts[1].rock.size(), kMaxPoints);
  EXPECT_EQ(parts[2].rock.size(), 5000u);
  EXPECT_EQ(parts[0].tracks.size(), 1u);
  EXPECT_TRUE(parts[1].tracks.empty() && parts[2].tracks.empty());
  EXPECT_EQ(parts[2].rock.back(), m.rock.back());
  EXPECT_EQ(splitObstacles(Obstacles{}).size(), 1u);  // tracks alone, or nothing new: one message
}

// Each typed message, written by the robot's toJson and read by the parser both ends use, is
// itself again; and what only the centre knows (the map's bounds) is checked on the typed value.
TEST(Messages, EachTypeReadsBackAsWrittenWithTheParserBothEndsUse) {
  Telemetry telemetry;
  telemetry.t = 1.5;
  telemetry.pose = {1, 2, 3};
  telemetry.velocity = {0.5, -0.25, 0};
  telemetry.status = "detouring";
  telemetry.goal = map::Vec3(5, 0, 1);
  telemetry.min_clearance = 0.75;
  Plan plan;
  plan.t = 2;
  plan.reason = "replan";
  plan.path = {{0, 0, 1}, {4, 0, 1}, {4, 3, 1}};
  plan.labels = {"A", "B"};
  Obstacles obstacles;
  obstacles.t = 3;
  obstacles.rock = {{1, 1, 1}, {2, 2, 2}};
  obstacles.tracks.push_back({"v7", {3, 0, 1}, {0, 0.5, 0}, 1.25});
  Event event;
  event.t = 4;
  event.at = 3.5;
  event.kind = "roof_fall";
  event.center = map::Vec3(6, 0, 1);
  event.radius = 2;
  CommandResult result;
  result.t = 5;
  result.command_id = 42;
  result.result = "executed";
  result.reason = "at the goal";
  const auto roundTrip = [](const auto& m) {
    const std::string text = toJson(m);
    StatusOr<protocol::Body> back = protocol::parseBody(protocol::Json::parse(text));
    EXPECT_TRUE(back.ok()) << text << ": " << back.status().message();
    if (!back.ok()) return;
    using T = std::decay_t<decltype(m)>;
    ASSERT_TRUE(std::holds_alternative<T>(*back)) << text;
    EXPECT_EQ(toJson(std::get<T>(*back)), text);
  };
  roundTrip(telemetry);
  // A ground robot's heading and box body (the viewer draws that box).
  Telemetry ground = telemetry;
  ground.yaw = -2.5;
  ground.body = map::Vec3(1.0, 0.7, 0.6);
  roundTrip(ground);
  const auto refusal = [&](const char* key, const protocol::Json& value) {
    protocol::Json j = protocol::Json::parse(toJson(ground));
    j[key] = value;
    StatusOr<protocol::Body> back = protocol::parseBody(j);
    return back.ok() ? std::string("accepted") : back.status().message();
  };
  EXPECT_EQ(refusal("body", protocol::Json::array({1.0, -0.7, 0.6})),
            "field 'body' must be [length, width, height], each in (0, 20] m");
  EXPECT_EQ(refusal("body", protocol::Json::array({1.0, 0.7, 25.0})),
            "field 'body' must be [length, width, height], each in (0, 20] m");
  EXPECT_NE(refusal("body", protocol::Json::array({1.0, 0.7})).find("body"), std::string::npos);
  // A round ground robot: a cylinder, [diameter, diameter, height].
  Telemetry round = ground;
  round.body = map::Vec3(0.6, 0.6, 0.5);
  round.body_shape = "cylinder";
  roundTrip(round);
  EXPECT_EQ(refusal("body_shape", "sphere"), "field 'body_shape' must be 'box' or 'cylinder'");
  EXPECT_EQ(refusal("body_shape", 3), "field 'body_shape' must be a string");
  EXPECT_EQ(refusal("body_shape", "box"), "accepted");
  {
    protocol::Json j = protocol::Json::parse(toJson(round));
    j["body"] = protocol::Json::array({0.6, 0.4, 0.5});
    StatusOr<protocol::Body> back = protocol::parseBody(j);
    ASSERT_FALSE(back.ok());
    EXPECT_EQ(back.status().message(), "field 'body' of a cylinder must be [diameter, diameter, height]");
    j.erase("body");
    back = protocol::parseBody(j);
    ASSERT_FALSE(back.ok());
    EXPECT_EQ(back.status().message(), "field 'body_shape' needs a 'body'");
  }
  EXPECT_EQ(refusal("yaw", 1e6), "field 'yaw' must be within 100 rad of 0");
  EXPECT_EQ(refusal("yaw", "north"), "field 'yaw' must be a number");
  EXPECT_EQ(refusal("yaw", nullptr), "accepted");
  roundTrip(plan);
  roundTrip(obstacles);
  roundTrip(event);
  roundTrip(result);

  map::Aabb mine;
  mine.min = {-10, -10, -10};
  mine.max = {10, 10, 10};
  EXPECT_TRUE(protocol::checkWithin(protocol::Body(plan), mine).ok());
  plan.path.push_back({40, 0, 1});
  EXPECT_NE(protocol::checkWithin(protocol::Body(plan), mine).message().find("field 'path[3]' [40, 0, 1] is outside the map"),
            std::string::npos);
  obstacles.tracks[0].radius = 500;
  EXPECT_EQ(protocol::checkWithin(protocol::Body(obstacles), mine).message(), "field 'tracks[0].radius' must be in [0, 100] m");
  telemetry.velocity = {60, 0, 0};
  EXPECT_NE(protocol::checkWithin(protocol::Body(telemetry), mine).message().find("faster than 50 m/s"), std::string::npos);
}

// The typed messages a robot's code sends (messages.hpp) are what the centre accepts and stores.
TEST_F(ServerTest, TheTypedMessagesOfARobotAreStoredAsSent) {
  RobotHello hello;
  hello.robot = "r-typed";
  hello.map = "junction.yaml";
  hello.map_hash = g_map_hash;
  LinkOptions options;
  options.token = kToken;
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect("ws://127.0.0.1:" + std::to_string(port()), hello, options);
  ASSERT_TRUE(link.ok()) << link.status().message();
  Plan plan;
  plan.path = {{1, 0, 1}, {6, 0, 1}, {12, 0, 1}};
  plan.labels = {"A"};
  ASSERT_TRUE((*link)->send(plan).ok());
  Telemetry telemetry;
  telemetry.t = 0.1;
  telemetry.pose = {1.5, 0, 1};
  telemetry.velocity = {0.5, 0, 0};
  telemetry.goal = map::Vec3(12, 0, 1);
  telemetry.min_clearance = 1.25;
  ASSERT_TRUE((*link)->send(telemetry).ok());
  Obstacles obstacles;
  obstacles.t = 0.2;
  obstacles.rock = {{6, 1.4, 1}};
  obstacles.tracks.push_back({"v1", {9, 0, 1}, {-0.5, 0, 0}, 0.8});
  ASSERT_TRUE((*link)->send(obstacles).ok());
  Event event;
  event.t = 0.3;
  event.at = 0.25;
  event.kind = "roof_fall";
  event.center = map::Vec3(6, 0, 1);
  event.radius = 1.5;
  ASSERT_TRUE((*link)->send(event).ok());
  // What the centre would refuse, the link refuses before it takes a seq, in the centre's words
  // (both ends read a message with the same parser).
  Telemetry unknown = telemetry;
  unknown.status = "dancing";
  const StatusOr<std::uint64_t> refused = (*link)->send(unknown);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().message(), "link: unknown status 'dancing'");
  Plan long_label = plan;
  long_label.labels = {std::string(65, 'L')};
  EXPECT_EQ((*link)->send(long_label).status().message(), "link: field 'labels[0]' is longer than 64 bytes (UTF-8)");
  Event no_kind = event;
  no_kind.kind = std::string(5000, 'k');  // also over the 4 KiB of a small message
  EXPECT_FALSE((*link)->send(no_kind).ok());
  EXPECT_EQ((*link)->send(R"({"type": "telemetry", "t": 1})").status().message(), "link: missing field 'pose'");
  EXPECT_EQ((*link)->send(R"({"type": "gossip", "t": 1})").status().message(), "link: unknown message type 'gossip'");
  EXPECT_FALSE((*link)->answer(0, "executed", "", 1.0).ok());  // command ids start at 1
  ASSERT_TRUE((*link)->flush(10.0));
  EXPECT_TRUE((*link)->stats().last_error.empty()) << (*link)->stats().last_error;
  EXPECT_EQ((*link)->stats().acked_seq, 4u);  // the refused took no seq
  const Json h = get("/api/history?robot=r-typed").json();
  ASSERT_EQ(h.size(), 4u) << h.dump();
  EXPECT_EQ(h[0]["type"], "plan");
  EXPECT_EQ(h[0]["labels"], Json({"A"}));
  EXPECT_EQ(h[1]["type"], "telemetry");
  EXPECT_EQ(h[1]["status"], "following");
  EXPECT_EQ(h[1]["subgoal"], nullptr);
  EXPECT_EQ(h[1]["min_clearance"], 1.25);
  EXPECT_EQ(h[2]["tracks"][0]["id"], "v1");
  EXPECT_EQ(h[2]["rock"], Json::array({Json::array({6, 1.4, 1})}));
  EXPECT_EQ(h[3]["kind"], "roof_fall");
  EXPECT_EQ(h[3]["at"], 0.25);
  EXPECT_EQ(h[3]["radius"], 1.5);
}

TEST_F(ServerTest, ASecondConnectionOfARobotReplacesTheFirstAndGetsItsCommands) {
  WsClient first(port(), "/ws/robot");
  first.hello("r-twice");
  WsClient second(port(), "/ws/robot");
  second.hello("r-twice");
  // The first is told and closed: commands can no longer reach two connections.
  const Json told = first.recv();
  EXPECT_EQ(told["type"], "error");
  EXPECT_NE(told.value("reason", "").find("replaced by a newer connection"), std::string::npos) << told.dump();
  EXPECT_EQ(first.closeCode(), static_cast<int>(websocket::close_code::policy_error));
  const Reply r = post({{"robot", "r-twice"}, {"kind", "pause"}});
  ASSERT_EQ(r.status, 202) << r.body;
  const Json c = second.recv();
  EXPECT_EQ(c["type"], "command");
  EXPECT_EQ(c["kind"], "pause");
}

TEST_F(ServerTest, ASeqFarBeyondTheLastStoredIsRefused) {
  // The issue's brick: one message with a huge seq used up the robot's range. Now a seq more than
  // 1,000,000 beyond the last stored is refused and stores nothing; the robot goes on from 1.
  WsClient robot(port(), "/ws/robot");
  EXPECT_EQ(robot.hello("r-gap"), 0);
  robot.send(telemetry("r-gap", kMaxSeqGap + 1));
  const Json e = robot.recv();
  EXPECT_EQ(e["type"], "error");
  EXPECT_NE(e.value("reason", "").find("is more than 1000000 beyond the last stored (0)"), std::string::npos) << e.dump();
  robot.send(telemetry("r-gap", kMaxSeqGap));  // within the window: stored
  EXPECT_EQ(robot.recv()["type"], "ack");
  EXPECT_EQ(stored("r-gap"), 1u);
}

TEST_F(ServerTest, AHelloWithAnAbsurdRadiusIsRefused) {
  WsClient robot(port(), "/ws/robot");
  robot.send(Json{{"type", "hello"}, {"robot", "r-huge"}, {"map", "junction.yaml"}, {"map_hash", g_map_hash}, {"radius", 1e308}});
  const Json e = robot.recv();
  EXPECT_EQ(e["type"], "error");
  EXPECT_NE(e.value("reason", "").find("'radius' must be in (0, 10] m"), std::string::npos) << e.dump();
}

TEST_F(ServerTest, AViewerTooSlowForWhatCannotBeDroppedIsClosedNotGrown) {
  // Plans are never dropped for a viewer (only telemetry is): 100 plans of about 180 KB to a
  // viewer that reads nothing is 18 MB, over the fixture's 4 MiB queue (the default 32 MiB takes
  // 4 times the traffic, 23 s here, for the same path) plus what the loopback socket buffers hold
  // (at most 4 MiB: Linux's default tcp_wmem maximum). It is closed (1013) with what was queued,
  // not kept growing.
  net::io_context ioc;
  websocket::stream<tcp::socket> viewer(ioc);
  viewer.next_layer().open(tcp::v4());
  viewer.next_layer().set_option(net::socket_base::receive_buffer_size(4096));
  viewer.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port()));
  viewer.handshake("127.0.0.1", std::string("/ws/view?token=") + kToken);
  viewer.read_message_max(64 << 20);
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-plans");
  Json path = Json::array(), labels = Json::array();
  for (int i = 0; i < 5000; ++i) path.push_back({5.0 + 1e-3 * i, 0.123456789, 1.123456789});
  const int n = 100;
  for (int seq = 1; seq <= n; ++seq) {
    robot.send(Json{{"type", "plan"}, {"robot", "r-plans"}, {"seq", seq}, {"t", 0.1 * seq}, {"reason", "replan"},
                    {"path", path}, {"labels", labels}});
    EXPECT_EQ(robot.recv()["type"], "ack");
  }
  // Read until the close, or until every plan arrived (then it was not closed: a failure, and
  // the loop ends instead of waiting for a close that never comes).
  beast::error_code ec;
  int plans = 0;
  while (!ec && plans < n) {
    beast::flat_buffer b;
    viewer.read(b, ec);
    if (!ec && Json::parse(beast::buffers_to_string(b.data()), nullptr, false).value("type", "") == "plan") ++plans;
  }
  EXPECT_LT(plans, n);
  EXPECT_EQ(ec, websocket::error::closed) << ec.message();
  EXPECT_EQ(viewer.reason().code, websocket::close_code::try_again_later);
  expectHealthy();
}

TEST_F(ServerTest, PointsSpeedsAndRadiiOutsideTheMineAreRefused) {
  WsClient robot(port(), "/ws/robot");
  robot.hello("r-where");
  auto refusedFor = [&](const Json& m) {
    robot.send(m);
    const Json e = robot.recv();
    EXPECT_EQ(e.value("type", ""), "error") << m.dump();
    return e.value("reason", std::string());
  };
  Json far = telemetry("r-where", 1);
  far["pose"] = {5.0e4, 0.0, 1.0};
  EXPECT_NE(refusedFor(far).find("field 'pose' [50000, 0, 1] is outside the map"), std::string::npos);
  Json fast = telemetry("r-where", 1);
  fast["velocity"] = {300.0, 0.0, 0.0};
  EXPECT_NE(refusedFor(fast).find("field 'velocity' [300, 0, 0] is faster than 50 m/s"), std::string::npos);
  Json goal = telemetry("r-where", 1);
  goal["goal"] = {0.0, 0.0, -1.0e6};
  EXPECT_NE(refusedFor(goal).find("field 'goal'"), std::string::npos);
  const Json plan{{"type", "plan"}, {"robot", "r-where"}, {"seq", 1}, {"t", 0.0}, {"reason", "initial"},
                  {"path", {{1, 0, 1}, {1e5, 0, 1}}}, {"labels", {"A"}}};
  EXPECT_NE(refusedFor(plan).find("field 'path[1]'"), std::string::npos);
  const Json track{{"type", "obstacles"}, {"robot", "r-where"}, {"seq", 1}, {"t", 0.0},
                   {"tracks", {{{"id", "v"}, {"position", {3, 0, 1}}, {"velocity", {0, 0, 0}}, {"radius", 1e4}}}}};
  EXPECT_NE(refusedFor(track).find("field 'tracks[0].radius' must be in [0, 100] m"), std::string::npos);
  const Json event{{"type", "event"}, {"robot", "r-where"}, {"seq", 1}, {"t", 0.0}, {"kind", "roof_fall"},
                   {"center", {-1e5, 0, 1}}, {"radius", 1.0}};
  EXPECT_NE(refusedFor(event).find("field 'center'"), std::string::npos);
  Json padded = telemetry("r-where", 1);
  padded["note"] = std::string(5000, 'n');
  EXPECT_NE(refusedFor(padded).find("a telemetry message of 5"), std::string::npos);
  // Nothing of them was stored; the same seq inside the mine is.
  EXPECT_EQ(stored("r-where"), 0u);
  robot.send(telemetry("r-where", 1));
  EXPECT_EQ(robot.recv()["type"], "ack");
  EXPECT_EQ(stored("r-where"), 1u);
}

TEST_F(ServerTest, ARobotsTimeNeverGoesBackOnOneConnection) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-clock");
    Json m = telemetry("r-clock", 1);
    m["t"] = 5.0;
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
    m = telemetry("r-clock", 2);
    m["t"] = 5.0;  // the same period (a plan and its telemetry share t)
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
    m = telemetry("r-clock", 3);
    m["t"] = 4.0;
    robot.send(m);
    const Json e = robot.recv();
    EXPECT_EQ(e["type"], "error");
    EXPECT_EQ(e.value("seq", 0), 3);
    EXPECT_NE(e.value("reason", "").find("is before t 5"), std::string::npos) << e.dump();
    // The refused message did not move the clock: seq 3 at t 5.5 is fine, and a last-bit
    // rounding back (t_k + dt against (k + 1) dt) is not going back.
    m["t"] = 5.5;
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
    m = telemetry("r-clock", 4);
    m["t"] = 5.5 - 1e-12;
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
    // A resend of a stored seq is acknowledged whatever its t.
    m = telemetry("r-clock", 1);
    m["t"] = 5.0;
    robot.send(m);
    EXPECT_EQ(robot.recv()["type"], "ack");
  }
  // A new connection (a new run) may start its clock again.
  WsClient again(port(), "/ws/robot");
  EXPECT_EQ(again.hello("r-clock"), 4);
  Json m = telemetry("r-clock", 5);
  m["t"] = 0.0;
  again.send(m);
  EXPECT_EQ(again.recv()["type"], "ack");
  EXPECT_EQ(stored("r-clock"), 5u);
}

TEST_F(ServerTest, ARobotOverItsStoredQuotaIsRefusedAndTheQuotaSurvivesARestart) {
  ServerOptions o = options();
  o.quota.stored_bytes = std::int64_t{1} << 20;
  // Plans of about 135 KB: about 7 fit in 1 MiB.
  Json path = Json::array();
  for (int i = 0; i < 4000; ++i) path.push_back({5.0 + 1e-3 * i, 0.123456789, 1.123456789});
  auto plan = [&](std::int64_t seq) {
    return Json{{"type", "plan"}, {"robot", "r-quota"}, {"seq", seq}, {"t", 0.1 * seq}, {"reason", "replan"},
                {"path", path}, {"labels", Json::array()}};
  };
  // How many fit: the bodies' sizes differ by a few bytes (seq and t).
  std::int64_t fit = 0, total = 0;
  while (total + static_cast<std::int64_t>(plan(fit + 1).dump().size()) <= (std::int64_t{1} << 20))
    total += static_cast<std::int64_t>(plan(++fit).dump().size());
  ASSERT_GE(fit, 5);
  {
    auto side = startCentre(o);
    ASSERT_TRUE(side->ok());
    WsClient robot(side->port(), "/ws/robot");
    EXPECT_EQ(robot.hello("r-quota"), 0);
    for (std::int64_t seq = 1; seq <= fit; ++seq) {
      robot.send(plan(seq));
      ASSERT_EQ(robot.recv()["type"], "ack") << seq;
    }
    robot.send(plan(fit + 1));
    const Json e = robot.recv();
    EXPECT_EQ(e["type"], "error");
    EXPECT_NE(e.value("reason", "").find("quota of 1048576 (adit serve --robot-store-quota)"), std::string::npos)
        << e.dump();
    // A resend of a stored one is still acknowledged.
    robot.send(plan(1));
    EXPECT_EQ(robot.recv()["type"], "ack");
  }
  // Restarted, the centre reads what the robot has stored: still over.
  auto side = startCentre(o);
  ASSERT_TRUE(side->ok());
  WsClient robot(side->port(), "/ws/robot");
  EXPECT_EQ(robot.hello("r-quota"), fit);
  robot.send(plan(fit + 1));
  EXPECT_EQ(robot.recv()["type"], "error");
  // The fixture's centre, with the default quota, stores it.
  WsClient other(port(), "/ws/robot");
  EXPECT_EQ(other.hello("r-quota"), fit);
  other.send(plan(fit + 1));
  EXPECT_EQ(other.recv()["type"], "ack");
}

TEST_F(ServerTest, ARobotOverItsRateIsSlowedAndLosesNothing) {
  // The CLI's burst: 10x the rate, 2x the bandwidth (adit serve --robot-rate, --robot-bandwidth).
  ServerOptions o = options();
  o.quota.messages_per_s = 20.0;
  o.quota.burst_messages = 200.0;
  auto side = startCentre(o);
  ASSERT_TRUE(side->ok());
  WsClient robot(side->port(), "/ws/robot");
  robot.hello("r-rate");
  // 220 messages at once: the 20 beyond the burst take at least 1 s at 20 a second. (Only the
  // lower bound is asserted: a loaded machine is slower, never faster.)
  const int n = 220;
  const auto start = std::chrono::steady_clock::now();
  for (int seq = 1; seq <= n; ++seq) robot.send(telemetry("r-rate", seq));
  int acks = 0;
  while (acks < n) {
    const Json a = robot.recv();
    ASSERT_EQ(a["type"], "ack") << a.dump();
    ++acks;
  }
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(took, 0.9) << "20 messages beyond the burst at 20/s";
  // All stored, in order, none lost.
  const Reply h = get("/api/history?robot=r-rate&limit=1000");
  ASSERT_EQ(h.status, 200);
  ASSERT_EQ(h.json().size(), static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) EXPECT_EQ(h.json()[static_cast<std::size_t>(i)]["seq"], i + 1);

  // The bytes: 10 plans of about 135 KB at 256 KiB/s with a burst of 512 KiB take >= 2.5 s.
  ServerOptions b = options();
  b.quota.bytes_per_s = 256.0 * 1024;
  b.quota.burst_bytes = 2.0 * b.quota.bytes_per_s;
  auto slow = startCentre(b);
  ASSERT_TRUE(slow->ok());
  WsClient big(slow->port(), "/ws/robot");
  big.hello("r-bandwidth");
  Json path = Json::array();
  for (int i = 0; i < 4000; ++i) path.push_back({5.0 + 1e-3 * i, 0.123456789, 1.123456789});
  // The wait after a message is for the next one: the last one's ack comes before its wait.
  std::size_t bytes = 0, last = 0;
  const auto t0 = std::chrono::steady_clock::now();
  const int plans = 10;
  for (int seq = 1; seq <= plans; ++seq) {
    const std::string text = Json{{"type", "plan"}, {"robot", "r-bandwidth"}, {"seq", seq}, {"t", 0.1 * seq},
                                  {"reason", "replan"}, {"path", path}, {"labels", Json::array()}}
                                 .dump();
    bytes += text.size();
    last = text.size();
    big.send(text);
  }
  for (int k = 0; k < plans; ++k) ASSERT_EQ(big.recv()["type"], "ack");
  const double took_bytes = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double expected = (double(bytes - last) - b.quota.burst_bytes) / b.quota.bytes_per_s - 0.1;
  EXPECT_GE(took_bytes, expected) << bytes << " bytes";
  EXPECT_GE(expected, 2.0);
}

// Runs last in the suite (gtest keeps the file's order): a restarted centre resumes from the
// database (acked seq, last telemetry in the snapshot).
TEST_F(ServerTest, ZRestartedServerResumesFromTheDatabase) {
  {
    WsClient robot(port(), "/ws/robot");
    robot.hello("r-restart");
    robot.send(Json{{"type", "plan"}, {"robot", "r-restart"}, {"seq", 1}, {"t", 0.0}, {"reason", "initial"},
                    {"path", {{1, 0, 1}, {12, 0, 1}}}, {"labels", {"A"}}});
    robot.recv();
    for (int seq = 2; seq <= 5; ++seq) {
      robot.send(telemetry("r-restart", seq, seq));
      robot.recv();
    }
    WsClient far(port(), "/ws/robot");
    far.hello("r-far");
    far.send(Json{{"type", "plan"}, {"robot", "r-far"}, {"seq", 1}, {"t", 0.0}, {"reason", "initial"},
                  {"path", {{1, 0, 1}, {12, 0, 1}}}, {"labels", {"A"}}});
    far.recv();
  }
  stopServer();
  {
    // The protocol's last seq, 2^53 - 1 away from the plan, written into the database directly
    // (the server now refuses such a jump, but a database may hold anything): the restart must
    // not walk the gap (paging backwards 5,000 seqs at a time, it once never finished).
    StatusOr<std::unique_ptr<Store>> db = Store::open(databaseUrl());
    ASSERT_TRUE(db.ok()) << db.status().toString();
    RobotMessage m;
    m.robot = "r-far";
    m.seq = kMaxSeq;
    m.type = "telemetry";
    m.t = 1.0;
    m.received_at = "2026-12-02T00:00:00.000Z";
    m.body = telemetry("r-far", kMaxSeq, 1.0).dump();
    m.pose = RobotMessage::Pose{1.0, 0.0, 1.0, 0.0, 0.0, 0.0, "following"};
    ASSERT_TRUE((*db)->appendMessage(m).ok());
  }
  startServer();
  WsClient viewer(port(), "/ws/view");
  const Json snap = viewer.recv();
  bool found = false;
  for (const Json& r : snap["robots"])
    if (r["robot"] == "r-restart") {
      found = true;
      EXPECT_EQ(r["telemetry"]["seq"], 5);
      EXPECT_EQ(r["plan"]["seq"], 1);
    } else if (r["robot"] == "r-far") {
      EXPECT_EQ(r["telemetry"]["seq"], kMaxSeq);
      EXPECT_EQ(r["plan"]["seq"], 1);
    }
  EXPECT_TRUE(found);
  WsClient robot(port(), "/ws/robot");
  EXPECT_EQ(robot.hello("r-restart"), 5);
}

}  // namespace
}  // namespace adit::console
