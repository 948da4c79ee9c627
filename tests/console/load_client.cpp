// SPDX-License-Identifier: BSD-3-Clause
// The console's load figures (issue 11, "Figures"; never run by CTest): N robots sending
// telemetry at F Hz each to a running `adit serve` through the real RobotLink (seq, outbox,
// acks), and one viewer on /ws/view timing every telemetry from the robot's send() to its
// arrival at the viewer. Prints one JSON object: stored rows/s (acknowledged telemetry over the
// wall clock), latency p50/p99/max, telemetry the viewer missed, and the server's RSS (VmHWM and
// VmRSS from /proc, given --server-pid).
//
//   adit_console_load --url ws://127.0.0.1:8080 --map maps/district.yaml [--robots 10] [--hz 50]
//                     [--seconds 30] [--server-pid PID] [--attackers N]
//
// --attackers N adds N hostile connections holding a credential (the operator token), each as a
// robot id of its own, that send as fast as the centre reads: 180 KB plans and bursts of
// small messages, draining their acks so the centre does not drop them. The honest robots'
// history is then read back: every seq 1..n stored (gapless), and the JSON says so.
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "adit/console/robot_link.hpp"
#include "adit/map/content_hash.hpp"

namespace {

namespace beast = boost::beast;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

struct Args {
  std::string url = "ws://127.0.0.1:8080";
  std::string map = "maps/district.yaml";
  int robots = 10;
  double hz = 50.0;
  double seconds = 30.0;
  long server_pid = 0;
  int attackers = 0;
  std::string token;  // the operator token: the viewer's and every robot's credential
};

bool parseArgs(int argc, char** argv, Args* a) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--url") a->url = v;
    else if (k == "--map") a->map = v;
    else if (k == "--robots") a->robots = std::stoi(v);
    else if (k == "--hz") a->hz = std::stod(v);
    else if (k == "--seconds") a->seconds = std::stod(v);
    else if (k == "--server-pid") a->server_pid = std::stol(v);
    else if (k == "--token") a->token = v;
    else if (k == "--attackers") a->attackers = std::stoi(v);
    else return false;
  }
  return argc % 2 == 1 && a->robots > 0 && a->hz > 0 && a->seconds > 0 && a->attackers >= 0 && !a->token.empty();
}

// Send times of every (robot, seq), read by the viewer thread.
struct Timeline {
  std::mutex m;
  std::map<std::pair<std::string, std::uint64_t>, Clock::time_point> sent;
  std::vector<double> latency_ms;
};

std::string procStatus(long pid, const char* field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field, 0) == 0) return line.substr(line.find(':') + 1);
  return "";
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// GET target with the operator token; the body, or "" on any failure.
std::string httpGet(const std::string& host, const std::string& port, const std::string& target, const std::string& token) {
  try {
    net::io_context ioc;
    tcp::resolver resolver(ioc);
    beast::tcp_stream stream(ioc);
    stream.connect(resolver.resolve(host, port));
    beast::http::request<beast::http::string_body> req{beast::http::verb::get, target, 11};
    req.set(beast::http::field::host, host);
    req.set(beast::http::field::authorization, "Bearer " + token);
    beast::http::write(stream, req);
    beast::flat_buffer b;
    beast::http::response_parser<beast::http::string_body> p;
    p.body_limit(64 << 20);
    beast::http::read(stream, b, p);
    return p.get().result_int() == 200 ? p.get().body() : std::string();
  } catch (const std::exception&) {
    return "";
  }
}

// Every seq 1..n of the robot stored: the history read in pages.
bool gapless(const std::string& host, const std::string& port, const std::string& token, const std::string& robot,
             std::uint64_t n) {
  std::uint64_t next = 1;
  while (next <= n) {
    const Json page = Json::parse(httpGet(host, port, "/api/history?robot=" + robot + "&from=" + std::to_string(next) +
                                                          "&limit=10000", token),
                                  nullptr, false);
    if (!page.is_array() || page.empty()) return false;
    for (const Json& m : page) {
      if (m.value("seq", std::uint64_t{0}) != next) return false;
      ++next;
    }
  }
  return true;
}

// One hostile connection: a credential, its own robot id, sending as fast as the centre reads.
struct AttackStats {
  std::atomic<std::uint64_t> sent{0}, acked{0}, errors{0}, connections{0};
};

void attack(const std::string& host, const std::string& port, const std::string& token, const std::string& map_hash,
            const std::string& id, const std::atomic<bool>& running, AttackStats& stats) {
  // Its big messages are plans of 5,000 points (about 180 KB), the largest kind a robot sends.
  Json path = Json::array();
  for (int i = 0; i < 5000; ++i) path.push_back({60.0 + 1e-3 * i, 0.123456789, -2.123456789});
  std::uint64_t seq = 0;
  while (running) {
    try {
      net::io_context ioc;
      tcp::resolver resolver(ioc);
      beast::websocket::stream<tcp::socket> ws(ioc);
      net::connect(beast::get_lowest_layer(ws), resolver.resolve(host, port));
      ws.set_option(beast::websocket::stream_base::decorator([&token](beast::websocket::request_type& req) {
        req.set(beast::http::field::authorization, "Bearer " + token);
      }));
      ws.handshake(host, "/ws/robot");
      ws.text(true);
      ws.write(net::buffer(Json{{"type", "hello"}, {"robot", id}, {"map_hash", map_hash}, {"radius", 0.4}}.dump()));
      beast::flat_buffer b;
      ws.read(b);
      const Json w = Json::parse(beast::buffers_to_string(b.data()), nullptr, false);
      if (!w.is_object() || w.value("type", "") != "welcome") return;
      seq = std::max<std::uint64_t>(seq, w.value("acked_seq", std::uint64_t{0}));
      ++stats.connections;
      // One write and one read in flight on the connection's one thread (Beast allows exactly
      // that): the writes go as fast as the centre reads, the reads drain the acks and count the
      // errors so that the centre keeps the connection.
      std::function<void()> writeOne, readOne;
      std::string out;
      beast::flat_buffer rb;
      std::uint64_t k = 0;
      auto end = [&] {
        beast::error_code ignored;
        beast::get_lowest_layer(ws).close(ignored);  // cancels what is in flight
      };
      writeOne = [&] {
        if (!running) return ws.async_close(beast::websocket::close_code::normal, [&](beast::error_code) { end(); });
        Json m{{"type", "telemetry"}, {"robot", id},  {"seq", ++seq}, {"t", 1e-3 * double(seq)},
               {"pose", {60.0, 0.0, -2.0}}, {"velocity", {0.0, 0.0, 0.0}}, {"status", "following"}};
        if (k++ % 11 == 0)  // every 11th a plan of 180 KB, the rest small
          m = Json{{"type", "plan"}, {"robot", id}, {"seq", seq}, {"t", 1e-3 * double(seq)}, {"reason", "replan"},
                   {"path", path}, {"labels", Json::array()}};
        out = m.dump();
        ws.async_write(net::buffer(out), [&](beast::error_code ec, std::size_t) {
          if (ec) return end();
          ++stats.sent;
          writeOne();
        });
      };
      readOne = [&] {
        ws.async_read(rb, [&](beast::error_code ec, std::size_t) {
          if (ec) return end();
          const Json m = Json::parse(beast::buffers_to_string(rb.data()), nullptr, false);
          rb.consume(rb.size());
          if (m.value("type", "") == "ack") ++stats.acked;
          else if (m.value("type", "") == "error") ++stats.errors;
          readOne();
        });
      };
      writeOne();
      readOne();
      ioc.run();
    } catch (const std::exception&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!parseArgs(argc, argv, &a)) {
    std::fprintf(stderr, "usage: %s --url ws://HOST:PORT --map MAP --token T [--robots N] [--hz F] [--seconds S] [--server-pid P] [--attackers N]\n",
                 argv[0]);
    return 2;
  }
  const auto hash = adit::map::fileContentHash(a.map);
  if (!hash.ok()) {
    std::fprintf(stderr, "%s\n", hash.status().message().c_str());
    return 2;
  }
  const std::string hostport = a.url.substr(a.url.find("//") + 2);
  const std::string host = hostport.substr(0, hostport.rfind(':'));
  const std::string port = hostport.substr(hostport.rfind(':') + 1);

  Timeline tl;
  std::atomic<bool> viewing{true};
  std::atomic<std::uint64_t> viewer_telemetry{0}, lag_dropped{0};
  net::io_context ioc;
  beast::websocket::stream<tcp::socket> view(ioc);
  try {
    tcp::resolver resolver(ioc);
    net::connect(beast::get_lowest_layer(view), resolver.resolve(host, port));
    view.set_option(beast::websocket::stream_base::decorator([&a](beast::websocket::request_type& req) {
      req.set(beast::http::field::authorization, "Bearer " + a.token);
    }));
    view.handshake(host, "/ws/view");
    view.read_message_max(64 << 20);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "viewer: cannot connect to %s: %s\n", a.url.c_str(), e.what());
    return 2;
  }
  std::thread viewer([&] {
    beast::flat_buffer b;
    beast::error_code ec;
    while (viewing) {
      b.clear();
      view.read(b, ec);
      if (ec) return;
      const Clock::time_point now = Clock::now();
      const Json j = Json::parse(beast::buffers_to_string(b.data()), nullptr, false);
      if (!j.is_object()) continue;
      const std::string type = j.value("type", "");
      if (type == "lag") lag_dropped += j.value("dropped", std::uint64_t{0});
      if (type != "telemetry") continue;
      ++viewer_telemetry;
      std::lock_guard<std::mutex> lock(tl.m);
      auto it = tl.sent.find({j.value("robot", ""), j.value("seq", std::uint64_t{0})});
      if (it != tl.sent.end())
        tl.latency_ms.push_back(std::chrono::duration<double, std::milli>(now - it->second).count());
    }
  });

  std::vector<std::unique_ptr<adit::console::RobotLink>> links;
  const std::string run = std::to_string(static_cast<long long>(std::chrono::system_clock::now().time_since_epoch() /
                                                                  std::chrono::milliseconds(1)));
  for (int i = 0; i < a.robots; ++i) {
    adit::console::RobotHello hello;
    hello.robot = "load-" + run + "-" + std::to_string(i);
    hello.map = a.map.substr(a.map.find_last_of('/') + 1);
    hello.map_hash = *hash;
    adit::console::LinkOptions options;
    options.token = a.token;
    auto link = adit::console::RobotLink::connect(a.url, hello, options);
    if (!link.ok()) {
      std::fprintf(stderr, "robot %d: %s\n", i, link.status().message().c_str());
      return 2;
    }
    links.push_back(std::move(link).value());
  }
  std::atomic<bool> attacking{true};
  AttackStats attack_stats;
  std::vector<std::thread> attackers;
  for (int k = 0; k < a.attackers; ++k)
    attackers.emplace_back([&, k] {
      attack(host, port, a.token, *hash, "attack-" + run + "-" + std::to_string(k), attacking, attack_stats);
    });
  const Clock::time_point start = Clock::now();
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / a.hz));
  const auto steps = static_cast<std::uint64_t>(a.seconds * a.hz);
  std::vector<std::thread> robots;
  std::atomic<std::uint64_t> send_errors{0};
  for (int i = 0; i < a.robots; ++i)
    robots.emplace_back([&, i] {
      const std::string id = "load-" + run + "-" + std::to_string(i);
      // The robots start spread over one period, as independent robots would.
      const Clock::time_point t0 = start + period * i / a.robots;
      for (std::uint64_t k = 0; k < steps; ++k) {
        std::this_thread::sleep_until(t0 + period * k);
        const double t = static_cast<double>(k) / a.hz;
        const Json msg{{"type", "telemetry"},     {"t", t},
                       {"pose", {60.0 + 0.02 * t, 0.0, -2.0}}, {"velocity", {0.02, 0.0, 0.0}},
                       {"status", "following"},   {"goal", {130.0, 40.0, -3.5}},
                       {"subgoal", nullptr},      {"min_clearance", 1.0}};
        std::lock_guard<std::mutex> lock(tl.m);  // the send time is known before the viewer can see it
        const auto seq = links[static_cast<std::size_t>(i)]->send(msg.dump());
        if (!seq.ok()) ++send_errors;
        else tl.sent[{id, *seq}] = Clock::now();
      }
    });
  for (std::thread& t : robots) t.join();
  const double send_s = std::chrono::duration<double>(Clock::now() - start).count();
  bool flushed = true;
  for (auto& l : links) flushed = l->flush(60.0) && flushed;
  const double stored_s = std::chrono::duration<double>(Clock::now() - start).count();
  std::uint64_t acked = 0, dropped = 0;
  for (auto& l : links) {
    acked += l->stats().acked_seq;
    dropped += l->stats().dropped_telemetry;
  }
  attacking = false;
  for (std::thread& t : attackers) t.join();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the last pushes reach the viewer
  viewing = false;
  beast::error_code ec;
  view.close(beast::websocket::close_code::normal, ec);
  viewer.join();

  std::vector<double> lat;
  {
    std::lock_guard<std::mutex> lock(tl.m);
    lat = tl.latency_ms;
  }
  Json out{{"robots", a.robots},
           {"hz", a.hz},
           {"sent", steps * static_cast<std::uint64_t>(a.robots)},
           {"send_seconds", send_s},
           {"acked", acked},
           {"all_acked", flushed},
           {"seconds_until_all_stored", stored_s},
           {"stored_rows_per_s", static_cast<double>(acked) / stored_s},
           {"offered_rows_per_s", a.hz * a.robots},
           {"robot_dropped_telemetry", dropped},
           {"send_errors", send_errors.load()},
           {"viewer_telemetry", viewer_telemetry.load()},
           {"viewer_lag_dropped", lag_dropped.load()},
           {"latency_ms", {{"p50", quantile(lat, 0.5)}, {"p99", quantile(lat, 0.99)},
                           {"max", lat.empty() ? 0.0 : *std::max_element(lat.begin(), lat.end())}}}};
  bool all_gapless = true;
  for (int i = 0; i < a.robots; ++i)
    all_gapless = gapless(host, port, a.token, "load-" + run + "-" + std::to_string(i), steps) && all_gapless;
  out["honest_gapless"] = all_gapless;
  if (a.attackers > 0)
    out["attack"] = {{"connections", a.attackers},
                     {"reconnections", attack_stats.connections.load()},
                     {"sent", attack_stats.sent.load()},
                     {"acked", attack_stats.acked.load()},
                     {"refused", attack_stats.errors.load()}};
  if (a.server_pid > 0) {
    out["server_vmhwm"] = procStatus(a.server_pid, "VmHWM");
    out["server_vmrss"] = procStatus(a.server_pid, "VmRSS");
  }
  std::printf("%s\n", out.dump(2).c_str());
  return flushed && all_gapless ? 0 : 1;
}
