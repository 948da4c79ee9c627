// SPDX-License-Identifier: BSD-3-Clause
// The centre's alarms (console/doc/protocol.md, "Alarms"): raised from what robots send (their
// status, clearance) and from what they stop sending (stale telemetry, a lost link), stored with
// who acknowledged them and when, pushed to every viewer. The centre raises them itself rather
// than trusting a robot to report its own silence.
#include "ws_session.hpp"

namespace adit::console {
namespace {

using Clock = std::chrono::steady_clock;

// How often the stale check runs: a tenth of the shortest threshold the options allow would be
// finer than an operator can see; 100 ms is.
constexpr auto kStaleCheckEvery = std::chrono::milliseconds(100);
// How long a condition must stay ended before its alarm clears: a robot whose status flaps
// between collision and following at its message rate (or that reconnects in a loop) keeps one
// alarm raised instead of writing one a message, so the alarms table grows at most one row per
// robot, kind and second.
constexpr auto kAlarmSettle = std::chrono::seconds(1);

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// A period estimated from a robot sending as fast as it can is milliseconds: three figures.
std::string seconds(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// A robot that reported `arrived` has ended its mission: its silence and its hang-up are no
// alarm (the simulator, for one, writes its results between its last telemetry and its exit).
bool finished(const RobotCache& c) { return c.telemetry.is_object() && c.telemetry.value("status", "") == "arrived"; }

// A robot's own status names the condition: the alarm stands while the status does.
const char* statusAlarm(const std::string& status) {
  if (status == "collision") return "collision";
  if (status == "stuck") return "stuck";
  if (status == "no_route") return "no_route";
  return nullptr;
}

}  // namespace

const char* alarmSeverity(const std::string& kind) {
  if (kind == "collision" || kind == "lost_link") return "critical";
  if (kind == "clearance" || kind == "stuck" || kind == "no_route") return "major";
  return "minor";  // stale_telemetry: the link may be slow, not gone
}

Json alarmJson(const Alarm& a) {
  auto orNull = [](const std::string& s) { return s.empty() ? Json(nullptr) : Json(s); };
  return Json{{"type", "alarm"},
              {"alarm_id", a.alarm_id},
              {"robot", a.robot},
              {"kind", a.kind},
              {"severity", a.severity},
              {"message", a.message},
              {"raised_at", a.raised_at},
              {"cleared_at", orNull(a.cleared_at)},
              {"acked_at", orNull(a.acked_at)},
              {"acked_by", orNull(a.acked_by)},
              {"open", a.open()}};
}

void Server::Impl::warmAlarms() {
  auto open = store->alarms("", /*open_only=*/true, 10000);
  if (!open.ok()) {
    logLine("database: " + open.status().message());
    return;
  }
  for (const Alarm& a : *open) {
    open_alarms[a.alarm_id] = a;
    if (a.cleared_at.empty()) cache[a.robot].raised[a.kind] = a.alarm_id;
  }
}

Json Server::Impl::openAlarmsJson() const {
  Json out = Json::array();
  for (const auto& [id, a] : open_alarms) out.push_back(alarmJson(a));
  return out;
}

void Server::Impl::raiseAlarm(const std::string& robot, const std::string& kind, const std::string& message) {
  RobotCache& c = cache[robot];
  c.ending.erase(kind);
  if (c.raised.count(kind)) return;  // one alarm per condition while it lasts
  Alarm a;
  a.robot = robot;
  a.kind = kind;
  a.severity = alarmSeverity(kind);
  a.message = message;
  a.raised_at = protocol::isoNow();
  StatusOr<std::int64_t> id = store->addAlarm(a);
  if (!id.ok()) {
    logLine("database: " + id.status().message());
    return;
  }
  a.alarm_id = *id;
  c.raised[kind] = *id;
  open_alarms[*id] = a;
  logLine("alarm " + std::to_string(*id) + " (" + a.severity + ") robot " + robot + ": " + kind + ": " + message);
  broadcast(alarmJson(a), false);
}

void Server::Impl::endAlarm(const std::string& robot, const std::string& kind) {
  auto cached = cache.find(robot);
  if (cached == cache.end() || !cached->second.raised.count(kind)) return;
  cached->second.ending.emplace(kind, Clock::now());  // the first end counts
}

void Server::Impl::clearSettled() {
  const Clock::time_point now = Clock::now();
  for (auto& [robot, c] : cache) {
    std::vector<std::string> settled;
    for (const auto& [kind, since] : c.ending)
      if (now - since >= kAlarmSettle) settled.push_back(kind);
    for (const std::string& kind : settled) clearAlarm(robot, kind);
  }
}

void Server::Impl::clearAlarm(const std::string& robot, const std::string& kind) {
  auto cached = cache.find(robot);
  if (cached == cache.end()) return;
  cached->second.ending.erase(kind);
  auto raised = cached->second.raised.find(kind);
  if (raised == cached->second.raised.end()) return;
  const std::int64_t id = raised->second;
  cached->second.raised.erase(raised);
  const std::string now = protocol::isoNow();
  if (Status s = store->clearAlarm(id, now); !s.ok()) logLine("database: " + s.message());
  auto it = open_alarms.find(id);
  if (it == open_alarms.end()) return;
  it->second.cleared_at = now;
  broadcast(alarmJson(it->second), false);
  if (!it->second.open()) open_alarms.erase(it);
}

void Server::Impl::onTelemetryArrived(const std::string& robot, const Telemetry& m) {
  RobotCache& c = cache[robot];
  const Clock::time_point now = Clock::now();
  if (c.telemetry_at) {
    const double dt = std::chrono::duration<double>(now - *c.telemetry_at).count();
    // A running mean over about 16 arrivals: a resent burst after a reconnect pulls it down for
    // a moment only, and the stale threshold's floor covers that.
    c.estimated_period = c.estimated_period > 0.0 ? c.estimated_period + (dt - c.estimated_period) / 16.0 : dt;
  }
  c.telemetry_at = now;
  c.declared_period = m.period.value_or(0.0);
  endAlarm(robot, "stale_telemetry");
}

void Server::Impl::onTelemetryStored(const std::string& robot, const Telemetry& m) {
  const char* now = statusAlarm(m.status);
  for (const char* kind : {"collision", "stuck", "no_route"}) {
    if (now && std::strcmp(now, kind) == 0) {
      std::string message = "status " + m.status;
      char at[64];
      std::snprintf(at, sizeof at, " at (%.1f, %.1f, %.1f), t = %.1f s", m.pose.x(), m.pose.y(), m.pose.z(), m.t);
      raiseAlarm(robot, kind, message + at);
    } else {
      endAlarm(robot, kind);
    }
  }
  // No clearance reported: the robot does not know, and the alarm stays as it was.
  if (m.min_clearance) {
    if (*m.min_clearance < options.alarm_clearance_m)
      raiseAlarm(robot, "clearance",
                 "clearance " + metres(*m.min_clearance) + " m below the margin " + metres(options.alarm_clearance_m) + " m");
    else
      endAlarm(robot, "clearance");
  }
}

void Server::Impl::onRobotClosed(WsSession& session) {
  const std::string& robot = session.robotId();
  if (robot.empty()) return;
  auto current = robot_sessions.find(robot);
  // A connection replaced by a newer one of the same robot is no lost link.
  if (current == robot_sessions.end()) return;
  if (auto s = current->second.lock(); s && s.get() != &session && !s->dead()) return;
  RobotCache& c = cache[robot];
  if (finished(c)) {
    endAlarm(robot, "stale_telemetry");
    return;
  }
  const std::string status = c.telemetry.is_object() ? c.telemetry.value("status", "") : "";
  raiseAlarm(robot, "lost_link", "the robot's connection closed" + (status.empty() ? "" : " (last status " + status + ")"));
  endAlarm(robot, "stale_telemetry");  // the lost link says more
}

void Server::Impl::checkStale() {
  const Clock::time_point now = Clock::now();
  for (auto& [robot, c] : cache) {
    // A stale alarm whose telemetry came back is checked again: silent anew before it settled,
    // it stays raised.
    if (!c.telemetry_at || c.raised.count("lost_link") || finished(c)) continue;
    if (c.raised.count("stale_telemetry") && !c.ending.count("stale_telemetry")) continue;
    auto s = robot_sessions.find(robot);
    if (s == robot_sessions.end()) continue;
    auto session = s->second.lock();
    if (!session || session->dead()) continue;
    const double period = c.declared_period > 0.0 ? c.declared_period : c.estimated_period;
    if (!(period > 0.0)) continue;  // one telemetry so far: no period to be late against
    const double threshold = std::max(2.0 * period, options.alarm_stale_min_s);
    const double silent = std::chrono::duration<double>(now - *c.telemetry_at).count();
    if (silent > threshold)
      raiseAlarm(robot, "stale_telemetry",
                 "no telemetry for " + metres(silent) + " s (period " + seconds(period) + " s, threshold " +
                     metres(threshold) + " s)");
  }
}

void Server::Impl::startAlarmTimer() {
  alarm_timer.expires_after(kStaleCheckEvery);
  alarm_timer.async_wait([this](beast::error_code ec) {
    if (ec) return;
    checkStale();
    clearSettled();
    startAlarmTimer();
  });
}

}  // namespace adit::console
