// SPDX-License-Identifier: BSD-3-Clause
#include "adit/console/messages.hpp"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "adit/console/protocol_limits.hpp"

namespace adit::console {
namespace {

using Json = nlohmann::json;

Json point(const map::Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }
Json optionalPoint(const std::optional<map::Vec3>& v) { return v ? point(*v) : Json(nullptr); }
Json points(const std::vector<map::Vec3>& ps) {
  Json out = Json::array();
  for (const map::Vec3& p : ps) out.push_back(point(p));
  return out;
}

}  // namespace

std::string toJson(const Telemetry& m) {
  Json j{{"type", "telemetry"},
         {"t", m.t},
         {"pose", point(m.pose)},
         {"velocity", point(m.velocity)},
         {"status", m.status},
         {"goal", optionalPoint(m.goal)},
         {"subgoal", optionalPoint(m.subgoal)},
         {"min_clearance", m.min_clearance ? Json(*m.min_clearance) : Json(nullptr)},
         {"speed", m.speed ? Json(*m.speed) : Json(m.velocity.norm())}};
  if (m.period) j["period"] = *m.period;
  if (m.yaw) j["yaw"] = *m.yaw;
  if (m.body) j["body"] = point(*m.body);
  if (m.body_shape) j["body_shape"] = *m.body_shape;
  return j.dump();
}

std::string toJson(const Plan& m) {
  return Json{{"type", "plan"}, {"t", m.t}, {"reason", m.reason}, {"path", points(m.path)}, {"labels", m.labels}}.dump();
}

std::string toJson(const Obstacles& m) {
  Json tracks = Json::array();
  for (const TrackReport& r : m.tracks)
    tracks.push_back({{"id", r.id}, {"position", point(r.position)}, {"velocity", point(r.velocity)}, {"radius", r.radius}});
  return Json{{"type", "obstacles"}, {"t", m.t}, {"rock", points(m.rock)}, {"tracks", tracks}}.dump();
}

std::string toJson(const Event& m) {
  Json j{{"type", "event"}, {"t", m.t}, {"kind", m.kind}};
  if (m.at) j["at"] = *m.at;
  if (m.center) j["center"] = point(*m.center);
  if (m.radius) j["radius"] = *m.radius;
  return j.dump();
}

std::string toJson(const CommandResult& m) {
  return Json{{"type", "command_result"}, {"t", m.t}, {"command_id", m.command_id}, {"result", m.result},
              {"reason", m.reason}}
      .dump();
}

std::vector<Obstacles> splitObstacles(const Obstacles& m) {
  std::vector<Obstacles> out;
  std::size_t from = 0;
  do {
    Obstacles part;
    part.t = m.t;
    const std::size_t to = std::min(m.rock.size(), from + kMaxPoints);
    part.rock.assign(m.rock.begin() + static_cast<std::ptrdiff_t>(from), m.rock.begin() + static_cast<std::ptrdiff_t>(to));
    if (from == 0)
      part.tracks.assign(m.tracks.begin(), m.tracks.begin() + static_cast<std::ptrdiff_t>(std::min(m.tracks.size(), kMaxPoints)));
    out.push_back(std::move(part));
    from += kMaxPoints;
  } while (from < m.rock.size());
  return out;
}

}  // namespace adit::console
