// SPDX-License-Identifier: BSD-3-Clause
// A test client of `adit serve` speaking the robot protocol (console/doc/protocol.md): N robots,
// each walking along a survey roadway of the served map (GET /api/map) at 1 m/s of mission time,
// sending telemetry at F Hz (plus one plan with break-point labels and one obstacles message),
// waiting for each ack. With --viewer it also watches /ws/view and reports the robot → viewer
// latency (p50 / p99) and the stored messages per second. Used by the browser test (a robot to
// draw) and for the console's figures; never timed by CTest.
//
//   adit_console_feed 127.0.0.1:8080 [--robots N] [--hz F] [--seconds S] [--viewer] [--realtime]
//
// Prints "last ROBOT x,y,z" per robot (its final pose) and, with --viewer, the figures.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "console/beast_client.hpp"

namespace {

using namespace adit::console::testing;  // NOLINT: Beast's names and the client helpers
using Clock = std::chrono::steady_clock;

struct Args {
  std::string host = "127.0.0.1", port = "8080";
  int robots = 1;
  double hz = 20.0, seconds = 3.0;
  bool viewer = false, realtime = false;
  std::string token;  // the operator token (reads the map, opens both sockets)
};

Json fetchMap(const Args& a) {
  net::io_context ioc;
  tcp::resolver resolver(ioc);
  beast::tcp_stream stream(ioc);
  stream.connect(resolver.resolve(a.host, a.port));
  http::request<http::empty_body> req{http::verb::get, "/api/map", 11};
  req.set(http::field::host, a.host);
  req.set(http::field::authorization, "Bearer " + a.token);
  http::write(stream, req);
  beast::flat_buffer b;
  http::response<http::string_body> res;
  http::read(stream, b, res);
  return Json::parse(res.body());
}

// The point `s` metres along the polyline (clamped to its ends).
std::vector<double> along(const Json& line, double s) {
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const double dx = line[i + 1][0].get<double>() - line[i][0].get<double>();
    const double dy = line[i + 1][1].get<double>() - line[i][1].get<double>();
    const double dz = line[i + 1][2].get<double>() - line[i][2].get<double>();
    const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (s <= len || i + 2 == line.size()) {
      const double u = len > 0 ? std::min(1.0, s / len) : 0.0;
      return {line[i][0].get<double>() + u * dx, line[i][1].get<double>() + u * dy, line[i][2].get<double>() + u * dz};
    }
    s -= len;
  }
  return {line[0][0].get<double>(), line[0][1].get<double>(), line[0][2].get<double>()};
}

struct Latency {
  std::mutex mutex;
  std::map<std::pair<std::string, std::int64_t>, Clock::time_point> sent;
  std::vector<double> ms;
};

void runRobot(const Args& a, const Json& map, int index, Latency* latency, std::string* last) {
  net::io_context ioc;
  auto ws = openWebSocket(ioc, a.host, a.port, "/ws/robot", a.token);
  const std::string id = "r" + std::to_string(index + 1);
  const Json& road = map["roadways"][static_cast<std::size_t>(index) % map["roadways"].size()];
  const double lift = 0.6;  // centreline runs along the floor; the robot's centre is above it
  auto send = [&](const Json& j) {
    if (latency && j["type"] == "telemetry") {
      std::lock_guard<std::mutex> lock(latency->mutex);
      latency->sent[{id, j["seq"].get<std::int64_t>()}] = Clock::now();
    }
    ws.write(net::buffer(j.dump()));
  };
  auto recv = [&] { return readJson(ws); };
  send({{"type", "hello"}, {"robot", id}, {"map", map["name"]}, {"map_hash", map["hash"]}, {"radius", 0.4}});
  std::int64_t seq = recv().value("acked_seq", std::int64_t{0});
  Json path = Json::array(), labels = Json::array();
  for (const Json& p : road["centreline"]) path.push_back({p[0], p[1], p[2].get<double>() + lift});
  for (std::size_t i = 1; i < path.size(); ++i) labels.push_back(std::string(1, static_cast<char>('A' + (i - 1) % 26)));
  send({{"type", "plan"}, {"robot", id}, {"seq", ++seq}, {"t", 0.0}, {"reason", "initial"}, {"path", path}, {"labels", labels}});
  recv();
  const auto steps = static_cast<int>(std::lround(a.seconds * a.hz));
  const auto start = Clock::now();
  std::vector<double> pose;
  for (int k = 0; k <= steps; ++k) {
    const double t = k / a.hz;
    pose = along(road["centreline"], t * 1.0);
    pose[2] += lift;
    const std::vector<double> ahead = along(road["centreline"], t * 1.0 + 3.0);
    send({{"type", "telemetry"}, {"robot", id}, {"seq", ++seq}, {"t", t}, {"pose", pose}, {"velocity", {1.0, 0.0, 0.0}},
          {"status", "following"}, {"goal", path.back()}, {"subgoal", {ahead[0], ahead[1], ahead[2] + lift}},
          {"min_clearance", 1.5}});
    for (Json m = recv(); m.value("type", "") != "ack"; m = recv()) {
    }
    if (k == steps / 2) {
      send({{"type", "obstacles"}, {"robot", id}, {"seq", ++seq}, {"t", t}, {"rock", Json::array()},
            {"tracks", {{{"id", "v1"}, {"position", ahead}, {"velocity", {-0.5, 0.0, 0.0}}, {"radius", 1.0}}}}});
      recv();
    }
    if (a.realtime) std::this_thread::sleep_until(start + std::chrono::duration<double>((k + 1) / a.hz));
  }
  char buf[128];
  std::snprintf(buf, sizeof buf, "last %s %.6g,%.6g,%.6g", id.c_str(), pose[0], pose[1], pose[2]);
  *last = buf;
  ws.close(websocket::close_code::normal);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s HOST:PORT --token T [--robots N] [--hz F] [--seconds S] [--viewer] [--realtime]\n",
                 argv[0]);
    return 2;
  }
  const std::string hp = argv[1];
  a.host = hp.substr(0, hp.rfind(':'));
  a.port = hp.substr(hp.rfind(':') + 1);
  for (int i = 2; i < argc; ++i) {
    const std::string o = argv[i];
    if (o == "--token" && i + 1 < argc) a.token = argv[++i];
    else if (o == "--robots" && i + 1 < argc) a.robots = std::atoi(argv[++i]);
    else if (o == "--hz" && i + 1 < argc) a.hz = std::atof(argv[++i]);
    else if (o == "--seconds" && i + 1 < argc) a.seconds = std::atof(argv[++i]);
    else if (o == "--viewer") a.viewer = true;
    else if (o == "--realtime") a.realtime = true;
    else {
      std::fprintf(stderr, "unknown option %s\n", o.c_str());
      return 2;
    }
  }
  try {
    const Json map = fetchMap(a);
    if (map["roadways"].empty()) {
      std::fprintf(stderr, "the served map has no survey roadways to walk along\n");
      return 1;
    }
    Latency latency;
    std::atomic<long> viewed{0};
    std::thread viewer;
    net::io_context viewer_ioc;
    std::optional<websocket::stream<tcp::socket>> vws;
    if (a.viewer) {
      vws.emplace(openWebSocket(viewer_ioc, a.host, a.port, "/ws/view", a.token));
      viewer = std::thread([&] {
        beast::error_code ec;
        while (!ec) {
          beast::flat_buffer b;
          vws->read(b, ec);
          if (ec) break;
          const auto now = Clock::now();
          const Json m = Json::parse(beast::buffers_to_string(b.data()), nullptr, false);
          if (m.value("type", "") != "telemetry") continue;
          ++viewed;
          std::lock_guard<std::mutex> lock(latency.mutex);
          auto it = latency.sent.find({m["robot"].get<std::string>(), m["seq"].get<std::int64_t>()});
          if (it != latency.sent.end()) latency.ms.push_back(std::chrono::duration<double, std::milli>(now - it->second).count());
        }
      });
    }
    std::vector<std::string> last(static_cast<std::size_t>(a.robots));
    std::vector<std::thread> robots;
    const auto start = Clock::now();
    for (int i = 0; i < a.robots; ++i)
      robots.emplace_back(runRobot, std::cref(a), std::cref(map), i, a.viewer ? &latency : nullptr, &last[static_cast<std::size_t>(i)]);
    for (auto& t : robots) t.join();
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    for (const std::string& l : last) std::printf("%s\n", l.c_str());
    if (a.viewer) {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      beast::error_code ignored;
      vws->next_layer().shutdown(tcp::socket::shutdown_both, ignored);
      viewer.join();
      std::lock_guard<std::mutex> lock(latency.mutex);
      const double messages = static_cast<double>(latency.sent.size());
      std::printf("robots %d, %.0f Hz each, %.1f s: %zu telemetry sent, %ld viewed, %.0f stored messages/s\n", a.robots, a.hz,
                  elapsed, latency.sent.size(), viewed.load(), messages / elapsed);
      std::printf("robot -> viewer latency: p50 %.2f ms, p99 %.2f ms (n = %zu)\n", percentile(latency.ms, 0.5),
                  percentile(latency.ms, 0.99), latency.ms.size());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "adit_console_feed: %s\n", e.what());
    return 1;
  }
  return 0;
}
