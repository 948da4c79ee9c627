// SPDX-License-Identifier: BSD-3-Clause
// RobotLink against a minimal centre written here with Boost.Beast (the real one is `adit serve`):
// it accepts, answers hello with welcome.acked_seq from its ledger (the database), stores each
// (robot, seq) once and acks it, and can drop the connection mid-way or be killed and restarted
// on the same port. Proves protocol.md's promises: nothing lost, nothing duplicated, a command
// answered again from the stored result and never executed twice.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <limits>
#include <optional>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "adit/console/robot_link.hpp"

namespace adit::console {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;

// What the centre holds across restarts: the stored messages by seq, and how often a seq came.
// Polls `done` until it holds or `timeout_s` passes (generous: a loaded machine delays the link's
// thread, never the condition itself). The test then asserts on the condition, not on time.
template <class Pred>
bool waitFor(Pred done, double timeout_s = 30.0) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// A port nobody listens on for as long as it lives: bound (so no other process of a parallel test
// can take it) but not listening, so a connection to it is refused at once.
struct ClosedPort {
  ClosedPort() {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), len) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      ADD_FAILURE() << "cannot bind a loopback port";
    port = ntohs(a.sin_port);
  }
  ~ClosedPort() { ::close(fd); }
  int fd = -1;
  unsigned short port = 0;
};

struct Ledger {
  std::mutex mu;
  std::map<std::uint64_t, json> stored;
  std::map<std::uint64_t, int> received;
  int hellos = 0;
  int helloCount() {
    std::lock_guard lock(mu);
    return hellos;
  }
  std::uint64_t maxSeq() {
    std::lock_guard lock(mu);
    return stored.empty() ? 0 : stored.rbegin()->first;
  }
  std::vector<json> ofType(const std::string& type) {
    std::lock_guard lock(mu);
    std::vector<json> out;
    for (const auto& [seq, j] : stored)
      if (j["type"] == type) out.push_back(j);
    return out;
  }
};

struct CentreOptions {
  int drop_after = 0;                 // close the connection after storing this many (once)
  int drop_every = 0;                 // close every connection after storing this many on it
  std::vector<json> commands;         // sent after every welcome, as the centre resends pending ones
  std::string refuse;                 // answer hello with this error and close
  bool ack = true;
  std::optional<std::uint64_t> welcome_acked;  // what welcome says instead of the ledger's
  // Called with every newly stored message: what the centre sends back besides the ack (e.g. an
  // operator's command once the robot reached a place).
  std::function<std::vector<json>(const json&)> react;
};

class Centre {
 public:
  Centre(Ledger& ledger, CentreOptions opt, unsigned short port = 0) : ledger_(ledger), opt_(std::move(opt)) {
    tcp::endpoint ep(net::ip::make_address("127.0.0.1"), port);
    acceptor_.open(ep.protocol());
    acceptor_.set_option(net::socket_base::reuse_address(true));
    acceptor_.bind(ep);
    acceptor_.listen();
    port_ = acceptor_.local_endpoint().port();
    thread_ = std::thread([this] { serve(); });
  }
  ~Centre() { kill(); }
  unsigned short port() const { return port_; }
  std::string url() const { return "ws://127.0.0.1:" + std::to_string(port_); }

  // As a crash would: the listening socket and the live connection go at once.
  void kill() {
    if (!thread_.joinable()) return;
    stop_ = true;
    ::shutdown(acceptor_.native_handle(), SHUT_RDWR);
    {
      std::lock_guard lock(conn_mu_);
      if (conn_fd_ >= 0) ::shutdown(conn_fd_, SHUT_RDWR);
    }
    thread_.join();
  }

 private:
  void serve() {
    while (!stop_) {
      beast::error_code ec;
      tcp::socket sock(ioc_);
      acceptor_.accept(sock, ec);
      if (ec || stop_) return;
      {
        // kill() may have run between the accept and here: it shut down no connection then, so
        // look at stop_ again under the lock it takes.
        std::lock_guard lock(conn_mu_);
        if (stop_) return;
        conn_fd_ = sock.native_handle();
      }
      session(std::move(sock));
      std::lock_guard lock(conn_mu_);
      conn_fd_ = -1;
    }
  }

  void session(tcp::socket sock) {
    beast::error_code ec;
    websocket::stream<tcp::socket> ws(std::move(sock));
    ws.accept(ec);
    if (ec) return;
    beast::flat_buffer buf;
    ws.read(buf, ec);
    if (ec) return;
    const json hello = json::parse(beast::buffers_to_string(buf.data()));
    buf.consume(buf.size());
    if (hello["type"] != "hello") return;
    {
      std::lock_guard lock(ledger_.mu);
      ++ledger_.hellos;
    }
    ws.text(true);
    if (!opt_.refuse.empty()) {
      ws.write(net::buffer(json{{"type", "error"}, {"reason", opt_.refuse}}.dump()), ec);
      ws.close(websocket::close_code::policy_error, ec);
      return;
    }
    ws.write(net::buffer(json{{"type", "welcome"}, {"robot", hello["robot"]},
                              {"acked_seq", opt_.welcome_acked.value_or(ledger_.maxSeq())}}.dump()),
             ec);
    for (const json& c : opt_.commands) ws.write(net::buffer(c.dump()), ec);
    int stored_here = 0;
    for (;;) {
      ws.read(buf, ec);
      if (ec) return;
      const json m = json::parse(beast::buffers_to_string(buf.data()));
      buf.consume(buf.size());
      const std::uint64_t seq = m["seq"].get<std::uint64_t>();
      bool fresh = false;
      {
        std::lock_guard lock(ledger_.mu);
        ++ledger_.received[seq];
        fresh = ledger_.stored.emplace(seq, m).second;  // at most once per seq
      }
      ++stored_here;
      // What the centre answers goes out before the ack, so a robot that waits for its acks
      // (simulate --live-lockstep) holds the answer by the time the ack arrives.
      if (fresh && opt_.react)
        for (const json& out : opt_.react(m)) ws.write(net::buffer(out.dump()), ec);
      if (opt_.ack) ws.write(net::buffer(json{{"type", "ack"}, {"seq", seq}}.dump()), ec);
      if ((opt_.drop_after > 0 && stored_here == opt_.drop_after) ||
          (opt_.drop_every > 0 && stored_here % opt_.drop_every == 0)) {
        opt_.drop_after = 0;
        ::shutdown(ws.next_layer().native_handle(), SHUT_RDWR);  // no close frame: a lost link
        return;
      }
    }
  }

  Ledger& ledger_;
  CentreOptions opt_;
  net::io_context ioc_;
  tcp::acceptor acceptor_{ioc_};
  unsigned short port_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex conn_mu_;
  int conn_fd_ = -1;
};

RobotHello hello() {
  RobotHello h;
  h.robot = "r1";
  h.map = "district.yaml";
  h.map_hash = "fnv1a64:0123456789abcdef";
  h.radius_m = 0.4;
  return h;
}

std::string telemetry(int i) {
  return json{{"type", "telemetry"}, {"t", 0.1 * i}, {"pose", {i, 0, 1.6}}, {"velocity", {1, 0, 0}},
              {"status", "following"}, {"goal", {100, 0, 1.6}}, {"subgoal", nullptr}, {"min_clearance", 0.8}}
      .dump();
}

// Every seq 1..n stored exactly once, in content the one sent with it.
void expectComplete(Ledger& l, int n) {
  std::lock_guard lock(l.mu);
  ASSERT_EQ(l.stored.size(), std::size_t(n));
  for (int i = 1; i <= n; ++i) {
    ASSERT_TRUE(l.stored.count(std::uint64_t(i))) << "seq " << i << " lost";
    EXPECT_EQ(l.stored[std::uint64_t(i)]["robot"], "r1");
  }
}

TEST(RobotLink, ResendsAfterADroppedConnectionWithoutLossOrDuplicate) {
  Ledger ledger;
  Centre centre(ledger, {/*drop_after=*/30});
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
  ASSERT_TRUE(link.ok()) << link.status().message();
  for (int i = 1; i <= 100; ++i) ASSERT_EQ((*link)->send(telemetry(i)).value(), std::uint64_t(i));
  ASSERT_TRUE((*link)->flush(10.0)) << (*link)->stats().last_error;
  expectComplete(ledger, 100);
  for (int i = 1; i <= 100; ++i) EXPECT_DOUBLE_EQ(ledger.stored[std::uint64_t(i)]["t"].get<double>(), 0.1 * i);
  const LinkStats s = (*link)->stats();
  EXPECT_GE(s.connections, 2u);
  EXPECT_EQ(ledger.helloCount(), int(s.connections)) << "a reconnection that did not take: " << s.last_error;
  EXPECT_EQ(s.acked_seq, 100u);
  EXPECT_EQ(s.outbox, 0u);
}

// The link used to keep one read buffer for all its connections: an ack read off a connection
// just as the centre reset it stayed in the buffer, in front of the next connection's welcome,
// which then failed to parse and cost a spurious reconnection (about one drop in fifteen). Forty
// drops make that nearly certain to show, so each connection must take on the first try.
TEST(RobotLink, EveryReconnectionTakesAtTheFirstHelloAcrossManyDrops) {
  Ledger ledger;
  CentreOptions opt;
  opt.drop_every = 5;
  Centre centre(ledger, opt);
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
  ASSERT_TRUE(link.ok()) << link.status().message();
  for (int i = 1; i <= 200; ++i) ASSERT_TRUE((*link)->send(telemetry(i)).ok());
  ASSERT_TRUE((*link)->flush(60.0)) << (*link)->stats().last_error;
  expectComplete(ledger, 200);
  const LinkStats s = (*link)->stats();
  EXPECT_GE(s.connections, 40u);
  EXPECT_EQ(ledger.helloCount(), int(s.connections)) << "a reconnection that did not take: " << s.last_error;
  EXPECT_EQ(s.last_error.find("expected welcome"), std::string::npos) << s.last_error;
}

TEST(RobotLink, CentreKilledAndRestartedResumesFromItsLedger) {
  Ledger ledger;
  auto centre = std::make_unique<Centre>(ledger, CentreOptions{});
  const unsigned short port = centre->port();
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre->url(), hello());
  ASSERT_TRUE(link.ok()) << link.status().message();
  for (int i = 1; i <= 40; ++i) ASSERT_TRUE((*link)->send(telemetry(i)).ok());
  ASSERT_TRUE((*link)->flush(5.0));
  centre->kill();
  centre.reset();
  // The robot goes on while the centre is down: its messages wait in the outbox.
  for (int i = 41; i <= 80; ++i) ASSERT_TRUE((*link)->send(telemetry(i)).ok());
  EXPECT_TRUE(waitFor([&] { return !(*link)->stats().connected; })) << "the link never noticed the dead centre";
  EXPECT_EQ((*link)->stats().outbox, 40u);
  centre = std::make_unique<Centre>(ledger, CentreOptions{}, port);
  for (int i = 81; i <= 100; ++i) ASSERT_TRUE((*link)->send(telemetry(i)).ok());
  ASSERT_TRUE((*link)->flush(10.0)) << (*link)->stats().last_error;
  expectComplete(ledger, 100);
  std::lock_guard lock(ledger.mu);
  for (const auto& [seq, n] : ledger.received) EXPECT_EQ(n, 1) << "seq " << seq << " sent " << n << " times";
}

// A second run of the same robot (a new process: its counter starts afresh) goes on after the
// centre's acked_seq instead of sending seqs the centre takes for stored.
TEST(RobotLink, ASecondRunOfTheSameRobotContinuesTheSeq) {
  Ledger ledger;
  Centre centre(ledger, {});
  for (int run = 0; run < 2; ++run) {
    StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
    ASSERT_TRUE(link.ok()) << link.status().message();
    for (int i = 1; i <= 10; ++i) ASSERT_EQ((*link)->send(telemetry(i)).value(), std::uint64_t(10 * run + i));
    ASSERT_TRUE((*link)->flush(5.0));
  }
  expectComplete(ledger, 20);
}

TEST(RobotLink, ARepeatedCommandIsAnsweredFromTheStoredResultNotExecutedAgain) {
  Ledger ledger;
  CentreOptions opt;
  opt.commands = {json{{"type", "command"}, {"command_id", 7}, {"kind", "pause"}, {"operator", "alice"}},
                  json{{"type", "command"}, {"command_id", 8}, {"kind", "goal"}, {"goal", {1, 2, 3}}}};
  opt.drop_after = 3;  // after the results: the centre resends both commands on the next welcome
  Centre centre(ledger, opt);
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
  ASSERT_TRUE(link.ok()) << link.status().message();
  std::vector<ReceivedCommand> got;
  waitFor([&] {
    for (ReceivedCommand& c : (*link)->pollCommands()) got.push_back(std::move(c));
    return got.size() >= 2;
  });
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, 7);
  EXPECT_EQ(got[0].kind, "pause");
  EXPECT_EQ(got[0].operator_name, "alice");
  EXPECT_EQ(got[1].kind, "goal");
  EXPECT_EQ(*got[1].goal, map::Vec3(1, 2, 3));
  ASSERT_TRUE((*link)->answer(7, "accepted", "", 1.0).ok());
  ASSERT_TRUE((*link)->answer(7, "executed", "", 1.0).ok());
  ASSERT_TRUE((*link)->answer(8, "refused", "goal (1.0, 2.0, 3.0) is in rock", 1.0).ok());
  // The third stored message drops the link; on reconnect both commands come again.
  waitFor([&] { return (*link)->stats().duplicate_commands >= 2; });
  EXPECT_EQ((*link)->stats().duplicate_commands, 2u);
  EXPECT_TRUE((*link)->pollCommands().empty()) << "a command must never be executed twice";
  ASSERT_TRUE((*link)->flush(5.0));
  const std::vector<json> results = ledger.ofType("command_result");
  ASSERT_EQ(results.size(), 5u);
  EXPECT_EQ(results[3]["command_id"], 7);
  EXPECT_EQ(results[3]["result"], "executed");  // the last answer given
  EXPECT_EQ(results[4]["command_id"], 8);
  EXPECT_EQ(results[4]["result"], "refused");
  EXPECT_EQ(results[4]["reason"], "goal (1.0, 2.0, 3.0) is in rock");
}

TEST(RobotLink, AMalformedCommandIsRefusedWithTheReason) {
  Ledger ledger;
  CentreOptions opt;
  opt.commands = {json{{"type", "command"}, {"command_id", 9}, {"kind", "manual"}, {"velocity", {1, "x", 0}}},
                  json{{"type", "command"}, {"command_id", 10}, {"kind", "dance"}}};
  Centre centre(ledger, opt);
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
  ASSERT_TRUE(link.ok());
  waitFor([&] { return ledger.ofType("command_result").size() >= 2; });
  EXPECT_TRUE((*link)->pollCommands().empty());
  const std::vector<json> results = ledger.ofType("command_result");
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0]["result"], "refused");
  EXPECT_NE(results[0]["reason"].get<std::string>().find("velocity"), std::string::npos);
  EXPECT_NE(results[1]["reason"].get<std::string>().find("unknown command kind"), std::string::npos);
}

// The centre's numbers are checked like any input: a manual velocity beyond the protocol's
// limit is refused, not executed; an ack for a seq never sent acknowledges nothing; a welcome
// that leaves no seq to send (2^64 - 1 used to wrap the robot's counter to 0) fails the
// connection with what to do.
TEST(RobotLink, TheCentresNumbersAreCheckedToo) {
  {
    Ledger ledger;
    CentreOptions opt;
    opt.commands = {json{{"type", "command"}, {"command_id", 11}, {"kind", "manual"}, {"velocity", {1e308, 0, 0}}},
                    json{{"type", "command"}, {"command_id", 12}, {"kind", "manual"}, {"velocity", {3, 0, 0}}},
                    json{{"type", "command"}, {"command_id", 13}, {"kind", "goal"}, {"goal", {1e300, 0, 0}}},
                    json{{"type", "ack"}, {"seq", 99999999999ull}}};
    opt.ack = false;  // only the forged ack arrives
    Centre centre(ledger, opt);
    StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
    ASSERT_TRUE(link.ok()) << link.status().message();
    ASSERT_TRUE(waitFor([&] { return ledger.ofType("command_result").size() >= 3; }));
    EXPECT_TRUE((*link)->pollCommands().empty()) << "an out-of-range command reached the robot";
    for (const json& r : ledger.ofType("command_result")) {
      EXPECT_EQ(r["result"], "refused") << r.dump();
      EXPECT_TRUE(r["reason"].get<std::string>().find("at most 2 m/s") != std::string::npos ||
                  r["reason"].get<std::string>().find("within +-1e7 m") != std::string::npos)
          << r.dump();
    }
    const LinkStats s = (*link)->stats();
    EXPECT_EQ(s.acked_seq, 0u) << "a forged ack counted";
    EXPECT_EQ(s.outbox, 3u) << "the results must wait for their real acks";
  }
  {
    Ledger ledger;
    CentreOptions opt;
    opt.welcome_acked = std::numeric_limits<std::uint64_t>::max();
    Centre centre(ledger, opt);
    StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
    ASSERT_FALSE(link.ok());
    EXPECT_NE(link.status().message().find("give the robot another id"), std::string::npos) << link.status().message();
  }
}

TEST(RobotLink, ARefusingCentreOrNoCentreIsAClearError) {
  Ledger ledger;
  CentreOptions opt;
  opt.refuse = "map_hash fnv1a64:0123456789abcdef is not the served map's";
  {
    Centre centre(ledger, opt);
    StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello());
    ASSERT_FALSE(link.ok());
    EXPECT_NE(link.status().message().find("not the served map"), std::string::npos) << link.status().message();
  }
  const ClosedPort closed;
  LinkOptions o;
  o.connect_timeout_s = 0.5;
  StatusOr<std::unique_ptr<RobotLink>> none =
      RobotLink::connect("ws://127.0.0.1:" + std::to_string(closed.port), hello(), o);
  ASSERT_FALSE(none.ok());
  // Within connect_timeout_s: the message quotes it (connect() returns on the timeout, by its
  // condition variable, not after some retries' worth of wall time).
  EXPECT_NE(none.status().message().find("no console at"), std::string::npos) << none.status().message();
  EXPECT_NE(none.status().message().find("within 0.5 s"), std::string::npos) << none.status().message();
  for (const char* bad : {"http://127.0.0.1:8080", "ws://:8080", "ws://127.0.0.1:99999", "ws://127.0.0.1:x"})
    EXPECT_EQ(RobotLink::connect(bad, hello(), o).status().code(), StatusCode::kInvalidArgument) << bad;
  RobotHello h = hello();
  h.robot = "r 1";
  EXPECT_EQ(RobotLink::connect("ws://127.0.0.1:1", h, o).status().code(), StatusCode::kInvalidArgument);
}

TEST(RobotLink, AFullOutboxDropsTheOldestTelemetryNeverPlans) {
  Ledger ledger;
  CentreOptions opt;
  opt.ack = false;  // a centre that stores nothing: the outbox only grows
  Centre centre(ledger, opt);
  LinkOptions o;
  o.outbox_limit = 5;
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre.url(), hello(), o);
  ASSERT_TRUE(link.ok());
  ASSERT_TRUE((*link)->send(json{{"type", "plan"}, {"t", 0}, {"reason", "initial"}, {"path", json::array()},
                                 {"labels", json::array()}}.dump()).ok());
  for (int i = 1; i <= 20; ++i) ASSERT_TRUE((*link)->send(telemetry(i)).ok());
  const LinkStats s = (*link)->stats();
  EXPECT_EQ(s.outbox, 5u);
  EXPECT_EQ(s.dropped_telemetry, 16u);
  EXPECT_EQ(s.last_seq, 21u);
  EXPECT_FALSE((*link)->flush(0.2));
}

// Plans and command results are never dropped: with the outbox full of them send() waits until
// the centre acknowledges (here: a restarted centre whose welcome covers what it holds).
TEST(RobotLink, AFullOutboxOfPlansBlocksTheSenderUntilAcknowledged) {
  Ledger ledger;
  CentreOptions mute;
  mute.ack = false;
  auto centre = std::make_unique<Centre>(ledger, mute);
  const unsigned short port = centre->port();
  LinkOptions o;
  o.outbox_limit = 3;
  StatusOr<std::unique_ptr<RobotLink>> link = RobotLink::connect(centre->url(), hello(), o);
  ASSERT_TRUE(link.ok());
  const std::string plan =
      json{{"type", "plan"}, {"t", 0}, {"reason", "replan"}, {"path", json::array()}, {"labels", json::array()}}.dump();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*link)->send(plan).ok());
  std::atomic<bool> returned{false};
  std::thread sender([&] {
    EXPECT_EQ((*link)->send(plan).value(), 4u);
    returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(returned) << "a plan must wait, not be dropped";
  EXPECT_EQ((*link)->stats().dropped_telemetry, 0u);
  ASSERT_TRUE(waitFor([&] { return ledger.maxSeq() >= 3; }));
  centre.reset();  // killed; the restarted one answers welcome.acked_seq = 3
  centre = std::make_unique<Centre>(ledger, CentreOptions{}, port);
  sender.join();
  EXPECT_TRUE(returned);
  ASSERT_TRUE((*link)->flush(5.0));
  expectComplete(ledger, 4);
}

TEST(RobotLink, ParseCommandNamesTheField) {
  EXPECT_FALSE(parseCommand("not json").ok());
  EXPECT_FALSE(parseCommand(R"({"type":"command","kind":"pause"})").ok());
  EXPECT_NE(parseCommand(R"({"type":"command","command_id":1,"kind":"goal","goal":[1,2]})").status().message().find("goal"),
            std::string::npos);
  EXPECT_NE(parseCommand(R"({"type":"command","command_id":1,"kind":"block"})").status().message().find("roadway"),
            std::string::npos);
  const StatusOr<ReceivedCommand> c = parseCommand(R"({"type":"command","command_id":3,"kind":"block","roadway":"crosscut-90"})");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->roadway, "crosscut-90");
  EXPECT_TRUE(parseCommand(R"({"type":"command","command_id":4,"kind":"release"})").ok());
  // Ids outside 1..2^53-1, and one that a signed read would wrap to -1, are refused (issue 17).
  for (const char* id : {"0", "-3", "9007199254740992", "18446744073709551615", "1.5", "\"7\""})
    EXPECT_FALSE(parseCommand(std::string(R"({"type":"command","kind":"pause","command_id":)") + id + "}").ok()) << id;
  EXPECT_TRUE(parseCommand(R"({"type":"command","kind":"pause","command_id":9007199254740991})").ok());
}

#ifdef ADIT_TOOL_PATH
// `adit simulate --live` end to end against the test centre: a loop of four roadways; the
// operator blocks the south roadway the robot is on, pauses it, resumes it. The run still ends
// as without the console (arrived, same JSON), every message arrives once and in order.
class LiveSimulation : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "adit_live_" + std::to_string(::getpid());
    ASSERT_EQ(std::system(("mkdir -p " + dir_).c_str()), 0);
    std::ofstream(dir_ + "/loop.yaml") << R"(name: loop
resolution: 0.2
rock_shell: 0.6
stations: {A: [0, 0, 0], B: [24, 0, 0], C: [24, 16, 0], D: [0, 16, 0]}
sections: {drift: {shape: rectangle, width: 4.0, height: 3.2}}
roadways:
  - {name: south, section: drift, stations: [A, B]}
  - {name: east, section: drift, stations: [B, C]}
  - {name: north, section: drift, stations: [C, D]}
  - {name: west, section: drift, stations: [D, A]}
)";
    std::ofstream(dir_ + "/loop_run.yaml") << R"(name: loop-run
map: loop.yaml
start: [3, 0, 1.6]
goal: [21, 0, 1.6]
expected_path: plan
robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 10}
method: tian2016
dt: 0.1
t_max: 200
seed: 1
)";
  }
  void TearDown() override { (void)std::system(("rm -rf " + dir_).c_str()); }
  int simulate(const std::string& url, const std::string& extra = "--live-speed 0") {
    const std::string cmd = std::string(ADIT_TOOL_PATH) + " simulate " + dir_ + "/loop_run.yaml --live " + url +
                            " --out " + dir_ + "/run.json " + extra + " 2>" + dir_ + "/stderr.txt";
    const int rc = std::system(cmd.c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  }
  std::string dir_;
};

json command(int id, const std::string& kind, const char* field = nullptr, const json& value = nullptr) {
  json c{{"type", "command"}, {"command_id", id}, {"kind", kind}, {"operator", "alice"}};
  if (field) c[field] = value;
  return c;
}

// The operator's script: each command is sent, in order, on the first telemetry at or after its
// time (and, if given, in its status since `for_s` seconds), on the robot's clock, not the
// wall's. The runs use --live-lockstep and the centre answers before it acknowledges, so every
// command acts in the period after the telemetry that cued it, however loaded the machine.
struct Cue {
  double t;
  json command;
  const char* status = nullptr;
  double for_s = 0.0;
};

CentreOptions scripted(std::vector<Cue> script) {
  CentreOptions opt;
  auto next = std::make_shared<std::size_t>(0);
  auto since = std::make_shared<double>(-1.0);  // when the cue's status was first seen
  opt.react = [script = std::move(script), next, since](const json& m) -> std::vector<json> {
    if (m["type"] != "telemetry" || *next >= script.size()) return {};
    const Cue& c = script[*next];
    const double t = m["t"].get<double>();
    if (c.status) {
      if (m["status"] != c.status) return {};
      if (*since < 0.0) *since = t;
      if (t - *since < c.for_s) return {};
    }
    if (t < c.t) return {};
    ++*next;
    *since = -1.0;
    return {c.command};
  };
  return opt;
}

// The telemetry status a run's outcome ends with.
std::string finalStatus(const json& run) {
  const std::string o = run["outcome"];
  return o == "timeout" ? "" : o;
}

// What the centre stored, in seq order: plan reasons, "id:result" of the command results, the
// telemetry and its status changes.
struct Transcript {
  std::vector<std::string> plans, results, statuses;
  std::vector<json> telemetry;
};

Transcript transcript(Ledger& l) {
  std::lock_guard lock(l.mu);
  Transcript tr;
  for (const auto& [seq, m] : l.stored) {
    if (m["type"] == "plan") tr.plans.push_back(m["reason"]);
    if (m["type"] == "command_result")
      tr.results.push_back(std::to_string(m["command_id"].get<int>()) + ":" + m["result"].get<std::string>());
    if (m["type"] == "telemetry") {
      tr.telemetry.push_back(m);
      if (tr.statuses.empty() || tr.statuses.back() != m["status"]) tr.statuses.push_back(m["status"]);
    }
  }
  return tr;
}

TEST_F(LiveSimulation, OperatorBlocksPausesResumesAndTheRunArrives) {
  Ledger ledger;
  Centre centre(ledger, scripted({{1.0, command(1, "block", "roadway", "south")},
                                  {4.0, command(2, "pause")},
                                  {0.0, command(3, "resume"), "paused", 3.0}}));
  // How the run ends depends on where the robot was when the block came (the cue's period): a
  // valid run either way, whose end the console is told.
  const int rc = simulate(centre.url(), "--robot-id r1 --live-speed 0 --live-lockstep");
  ASSERT_TRUE(rc == 0 || rc == 1) << std::ifstream(dir_ + "/stderr.txt").rdbuf();
  json run;
  std::ifstream(dir_ + "/run.json") >> run;
  {
    std::lock_guard lock(ledger.mu);
    ASSERT_FALSE(ledger.stored.empty());
    EXPECT_EQ(ledger.stored.rbegin()->first, ledger.stored.size()) << "seq 1..N, none lost";
    for (const auto& [seq, n] : ledger.received) EXPECT_EQ(n, 1) << seq;
    const json& first = ledger.stored.begin()->second;
    EXPECT_EQ(first["type"], "plan");
    EXPECT_EQ(first["reason"], "initial");
    EXPECT_EQ(first["robot"], "r1");
  }
  const Transcript tr = transcript(ledger);
  EXPECT_EQ(tr.plans.at(1), "blocked");
  EXPECT_EQ(tr.results, (std::vector<std::string>{"1:accepted", "1:executed", "2:accepted", "2:executed", "3:accepted",
                                                  "3:executed"}));
  std::vector<json> paused;
  for (const json& m : tr.telemetry)
    if (m["status"] == "paused") paused.push_back(m);
  ASSERT_GE(paused.size(), 6u);  // 3 s of pause, telemetry every 0.1 s once braked
  // Held: once braked (at a_max from up to v_max: at most 2 s of the 3 s pause; how fast it was
  // going depends on where the pause found it), the paused robot does not move.
  std::size_t stopped = 0;
  while (stopped < paused.size() && paused[stopped]["speed"].get<double>() > 1e-9) ++stopped;
  ASSERT_LT(stopped + 5, paused.size()) << "the paused robot did not stop within the pause";
  const json& a = paused[stopped];
  const json& b = paused.back();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a["pose"][i].get<double>(), b["pose"][i].get<double>(), 1e-6);
  if (!finalStatus(run).empty()) {
    EXPECT_EQ(tr.telemetry.back()["status"], finalStatus(run));
  }
  if (rc == 0) {
    EXPECT_NEAR(tr.telemetry.back()["pose"][0].get<double>(), 21.0, 0.5);
  }
}

// An e-stop mid-run: the robot acknowledges it at once, holds still reporting status "estop",
// refuses to resume while it stands, and after the release waits for the operator's resume.
// Every telemetry message carries its clearance (the believed map's distance field less the
// radius) and speed.
TEST_F(LiveSimulation, AnEstopHoldsTheRobotUntilReleasedAndResumed) {
  Ledger ledger;
  Centre centre(ledger, scripted({{2.0, command(1, "estop")},
                                  {0.0, command(2, "resume"), "estop", 1.0},
                                  {0.0, command(3, "estop_release"), "estop", 2.0},
                                  {0.0, command(4, "resume"), "paused", 0.5}}));
  const int rc = simulate(centre.url(), "--live-speed 0 --live-lockstep");
  ASSERT_TRUE(rc == 0 || rc == 1) << std::ifstream(dir_ + "/stderr.txt").rdbuf();
  const Transcript tr = transcript(ledger);
  EXPECT_EQ(tr.results, (std::vector<std::string>{"1:accepted", "1:executed", "2:refused", "3:accepted", "3:executed",
                                                  "4:accepted", "4:executed"}));
  std::vector<json> held;
  for (const json& m : tr.telemetry)
    if (m["status"] == "estop") held.push_back(m);
  ASSERT_GE(held.size(), 10u);  // 2 s of e-stop at 0.1 s
  const json& a = held[held.size() / 2];
  const json& b = held.back();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a["pose"][i].get<double>(), b["pose"][i].get<double>(), 1e-6);
  EXPECT_NEAR(b["speed"].get<double>(), 0.0, 1e-6);
  // Released, the robot stays paused until resumed, then drives on.
  const auto released = std::find(tr.statuses.begin(), tr.statuses.end(), "estop");
  ASSERT_NE(released, tr.statuses.end());
  ASSERT_NE(released + 1, tr.statuses.end());
  EXPECT_EQ(*(released + 1), "paused");
  std::size_t with_clearance = 0;
  for (const json& m : tr.telemetry) {
    if (!m["min_clearance"].is_number()) continue;
    ++with_clearance;
    // The loop's drift is 4 m wide and 3.2 m high with the robot on its axis: at most 1.6 m of
    // the centre to rock, less the 0.4 m radius.
    EXPECT_GE(m["min_clearance"].get<double>(), 0.0);
    EXPECT_LE(m["min_clearance"].get<double>(), 1.6 - 0.4 + 0.2);
    const double v = std::hypot(m["velocity"][0].get<double>(), m["velocity"][1].get<double>(), m["velocity"][2].get<double>());
    EXPECT_NEAR(m["speed"].get<double>(), v, 1e-9);
  }
  EXPECT_EQ(with_clearance, tr.telemetry.size()) << "every telemetry message carries its clearance";
}

// A goal clicked by the operator, manual driving, release: the robot replans from where it was
// driven to and arrives at the new goal; the goal command is executed on arrival.
TEST_F(LiveSimulation, NewGoalManualDriveAndReleaseArriveAtTheOperatorsGoal) {
  Ledger ledger;
  Centre centre(ledger, scripted({{1.0, command(1, "goal", "goal", {0, 12, 1.6})},
                                  {2.0, command(2, "manual", "velocity", {0.5, 0.3, 0})},
                                  {0.0, command(3, "release"), "manual", 3.0}}));
  const int rc = simulate(centre.url(), "--live-speed 0 --live-lockstep");
  ASSERT_TRUE(rc == 0 || rc == 1) << std::ifstream(dir_ + "/stderr.txt").rdbuf();
  json run;
  std::ifstream(dir_ + "/run.json") >> run;
  const bool arrived = run["outcome"] == "arrived";
  if (arrived) {
    EXPECT_LT(run["final_goal_distance"].get<double>(), 0.5) << "at the operator's goal";
  }
  const Transcript tr = transcript(ledger);
  EXPECT_EQ(tr.plans, (std::vector<std::string>{"initial", "goal", "replan"}));
  EXPECT_EQ(tr.results, (std::vector<std::string>{"1:accepted", "2:accepted", "2:executed", "3:accepted", "3:executed",
                                                  arrived ? "1:executed" : "1:refused"}));
  EXPECT_NE(std::find(tr.statuses.begin(), tr.statuses.end(), "manual"), tr.statuses.end());
  EXPECT_NE(std::find(tr.statuses.begin(), tr.statuses.end(), "replanning"), tr.statuses.end());
  if (!finalStatus(run).empty()) {
    EXPECT_EQ(tr.telemetry.back()["status"], finalStatus(run));
  }
  EXPECT_EQ(tr.telemetry.back()["goal"], json({0, 12, 1.6}));
}

// A roof fall on the south roadway: the console gets the event, the rock the robot senses of it
// (voxel centres, each once) and the replanned path round the loop.
TEST_F(LiveSimulation, ARoofFallReachesTheConsoleAsEventRockAndReplan) {
  std::ofstream(dir_ + "/loop_run.yaml", std::ios::app) << "events:\n  - {t: 3, type: roof_fall, center: [14, 0, 1.6], radius: 3}\n";
  Ledger ledger;
  Centre centre(ledger, {});
  ASSERT_EQ(simulate(centre.url(), "--live-speed 0 --live-period 0.5"), 0) << std::ifstream(dir_ + "/stderr.txt").rdbuf();
  std::lock_guard lock(ledger.mu);
  std::vector<std::string> types;
  std::set<std::vector<double>> rock;
  double last_t = -1.0;
  int telemetry = 0;
  for (const auto& [seq, m] : ledger.stored) {
    if (types.empty() || types.back() != m["type"]) types.push_back(m["type"]);
    if (m["type"] == "event") {
      EXPECT_EQ(m["kind"], "roof_fall");
      EXPECT_EQ(m["center"], json({14, 0, 1.6}));
      EXPECT_EQ(m["radius"], 3.0);
    }
    if (m["type"] == "obstacles")
      for (const json& p : m["rock"]) {
        const std::vector<double> v = p.get<std::vector<double>>();
        EXPECT_TRUE(rock.insert(v).second) << "rock voxel sent twice";
        EXPECT_NEAR((map::Vec3(v[0], v[1], v[2]) - map::Vec3(14, 0, 1.6)).norm(), 3.0, 0.5) << "on the fall's surface";
      }
    if (m["type"] == "telemetry") {
      ++telemetry;
      EXPECT_GE(m["t"].get<double>(), last_t);
      last_t = m["t"].get<double>();
    }
  }
  EXPECT_EQ(types.at(0), "plan");
  const auto event = std::find(types.begin(), types.end(), "event");
  ASSERT_NE(event, types.end());
  EXPECT_LT(event - types.begin(), std::find(types.begin(), types.end(), "obstacles") - types.begin())
      << "the fall is announced before its rock";
  EXPECT_GT(rock.size(), 20u);
  bool replanned = false;
  for (const auto& [seq, m] : ledger.stored) replanned = replanned || (m["type"] == "plan" && m["reason"] == "replan");
  EXPECT_TRUE(replanned);
  // Every 0.5 s of mission time, plus a message on each status change (at most one a period).
  EXPECT_GT(telemetry, int(last_t / 0.5));
  EXPECT_LE(telemetry, int(last_t / 0.1) + 2);
}

TEST_F(LiveSimulation, NoConsoleIsExitTwoAndAGoalInRockIsRefused) {
  Ledger ledger;
  {
    const ClosedPort closed;
    EXPECT_EQ(simulate("ws://127.0.0.1:" + std::to_string(closed.port)), 2);
  }
  EXPECT_EQ(simulate("http://127.0.0.1:1"), 2);

  CentreOptions opt;
  opt.commands = {command(5, "goal", "goal", {12, 8, 1.6})};  // inside the loop: rock
  Centre centre(ledger, opt);
  ASSERT_EQ(simulate(centre.url()), 0);
  std::lock_guard lock(ledger.mu);
  int refused = 0;
  for (const auto& [seq, m] : ledger.stored) {
    EXPECT_EQ(m["robot"], "loop_run");  // the scenario file's stem
    if (m["type"] == "command_result") {
      EXPECT_EQ(m["result"], "refused");
      EXPECT_NE(m["reason"].get<std::string>().find("in rock"), std::string::npos) << m["reason"];
      ++refused;
    }
  }
  EXPECT_GE(refused, 1);
}
#endif

}  // namespace
}  // namespace adit::console
