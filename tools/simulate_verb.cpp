// SPDX-License-Identifier: BSD-3-Clause
// `adit simulate SCENARIO.yaml`: run a scenario through the local planner and report the run.
// Thin: load, call adit::sim::simulate (or adit::sim::simulateNavigated for scenarios with
// `expected_path: plan`, `robot.sensor_range` or `events`), write JSON / picture / page.
// `adit simulate --batch N --map M`: N randomized navigated runs (adit/sim/batch.hpp) on
// worker processes, a CSV row per run and a JSON summary.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <optional>
#include <iostream>
#include <chrono>
#include <cstdlib>
#include <limits>
#include <map>
#include <array>
#include <set>
#include <thread>


#include "adit/console/robot_link.hpp"
#include "adit/fusion/subgoal_selector.hpp"
#include "adit/map/content_hash.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/readers/import.hpp"
#include "adit/sim/batch.hpp"
#include "adit/sim/navigated_simulation.hpp"
#include "adit/sim/simulator.hpp"
#include "common/animation_page.hpp"
#include "common/batch_runner.hpp"
#include "adit/map/size_estimate.hpp"
#include "common/cli.hpp"
#include "common/figure.hpp"
#include "common/json_output.hpp"
#include "common/phase_times.hpp"
#include "common/plan_output.hpp"
#include "common/progress.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using namespace adit::local;
using namespace adit::sim;
using adit::map::Vec3;

struct SimulateArgs {
  std::string scenario;
  std::string out;
  std::string picture;
  std::string html;
  std::string replay;  // CAMPAIGN:INDEX
  bool quiet = false;
  bool no_refine = false, refine_replans = false;
  bool no_cache = false;
  // --batch
  std::string map;
  std::string csv;
  int batch = 0;
  int first = 0;  // --first: index of the first run (re-run part of a table)
  bool batch_given = false;
  int jobs = 1;
  std::uint64_t seed = 1;
  double t_max = 0.0;
  double max_separation = 150.0;
  // --live (issue 11)
  std::string live;
  double live_speed = 1.0;
  double live_period = 0.1;
  double live_flush = 30.0;
  std::string max_memory;  // empty: the machine's budget
  bool live_hold = false;
  bool live_lockstep = false;
  std::string robot_id;
  std::string live_token_file;
};


// `--live`: the navigated run drives the operations console (console/doc/protocol.md) through a
// RobotLink: telemetry every --live-period of mission time, the expected path on every (re)plan,
// newly sensed rock and the tracks, roof falls; the operator's commands are executed between
// periods through the Navigator's operator API and answered with command_result. Paced to
// --live-speed times real time (0: as fast as it goes).
//
// --live-hold: the robot waits at its start, paused, until the operator resumes it (a robot set
// down at a portal waits for the go); what the operator sends meanwhile (a goal, a block) acts
// before its first step. --live-lockstep: after each period's messages the run waits until the
// console has acknowledged them, so it never gets ahead of the console, and a command the
// console sends before its acknowledgement acts in the very next period whatever the machine's
// load (scripted operators, tests); the wait is bounded by --live-flush, after which the run goes
// on unlocked, saying so.
struct LiveOptions {
  double speed = 1.0;
  double period_s = 0.1;
  bool hold = false;
  bool lockstep = false;
  double lockstep_timeout_s = 30.0;
  bool quiet = false;
};

class LiveConsole final : public sim::NavigatedObserver {
 public:
  LiveConsole(console::RobotLink& link, double dt_s, const local::RobotLimits& robot, const LiveOptions& o)
      : link_(link), robot_(robot), dt_(dt_s), radius_(robot.radius_m), speed_(o.speed), period_(o.period_s), quiet_(o.quiet), hold_(o.hold),
        lockstep_(o.lockstep), lockstep_timeout_s_(o.lockstep_timeout_s) {}

  void started(const fusion::Navigator& nav, const map::Polyline& path) override {
    nav.read([&](const map::OccupancyMap& m, const map::DistanceField&) { resolution_ = m.resolution(); });
    wall0_ = std::chrono::steady_clock::now();
    sendPlan(0.0, path, "initial");
  }

  void beforeCycle(double t_s, fusion::Navigator& nav, const local::RobotState& state) override {
    if (hold_) {
      hold_ = false;
      holdUntilResumed(t_s, nav, state);
    }
    for (const console::ReceivedCommand& c : link_.pollCommands()) execute(t_s, nav, c);
  }

  void roofFall(const sim::ScenarioEvent& e) override {
    // A fall between two periods is sensed at the next: sent then (t never goes back, as the
    // console requires), with the moment it happened in `at`.
    console::Event m;
    m.t = e.t_s;
    m.at = e.t_s;
    m.kind = e.type;
    m.center = e.center;
    m.radius = e.radius_m;
    send(m);
  }

  void afterCycle(double t_s, const fusion::Navigator& nav, const fusion::NavigatorCycle& c,
                  const local::RobotState& state, const fusion::SensorScan& scan,
                  const std::vector<map::MovingObstacle>& tracks, const sim::SimulationResult& res) override {
    const double t = t_s + dt_;
    if (c.replanned) sendPlan(t, nav.expectedPath(), "replan");
    if (c.inserted_points > 0)
      for (const Vec3& p : scan.returns) {
        const Vec3 centre = ((p / resolution_).array().floor() + 0.5).matrix() * resolution_;
        if (sent_rock_.insert({centre.x(), centre.y(), centre.z()}).second) fresh_rock_.push_back(centre);
      }
    const bool collided = res.collisions > collisions_;
    collisions_ = res.collisions;
    const char* status = collided ? "collision" : fusion::consoleStatusName(c);
    if (t + 1e-9 >= next_telemetry_ || collided || std::strcmp(status, last_status_) != 0) {
      const bool steering = c.status == fusion::NavigatorStatus::kDriving;
      sendTelemetry(t, nav, state, status,
                    steering ? std::optional<Vec3>(c.subgoal.value_or(c.command.sub_goal)) : std::nullopt);
      if (!fresh_rock_.empty() || !tracks.empty()) sendObstacles(t, tracks);
      while (next_telemetry_ <= t + 1e-9) next_telemetry_ += period_;
    }
    last_status_ = status;
    if (lockstep_) awaitAcknowledgement(t);
    pace(t);
  }

  void finished(double t_s, const fusion::Navigator& nav, const local::RobotState& state,
                const sim::SimulationResult& res) override {
    const char* status = res.collisions > 0 ? "collision"
                         : res.outcome == Outcome::kArrived ? "arrived"
                         : res.outcome == Outcome::kNoRoute ? "no_route"
                         : res.outcome == Outcome::kStuck  ? "stuck"
                                                           : last_status_;
    sendTelemetry(t_s, nav, state, status, std::nullopt);
    if (goal_command_) {
      if (res.outcome == Outcome::kArrived) answer(*goal_command_, "executed", "arrived", t_s);
      else answer(*goal_command_, "refused", std::string("the run ended: ") + outcomeName(res.outcome), t_s);
    }
  }

 private:
  // Every message's t is at least the last one's: the console refuses a clock that goes back,
  // and the navigator's t_k + dt and the next period's t differ in the last bit.
  template <class Message>
  void send(Message m) {
    sent_t_ = std::max(sent_t_, m.t);
    m.t = sent_t_;
    const StatusOr<std::uint64_t> s = link_.send(m);
    if (!s.ok() && !quiet_) std::fprintf(stderr, "adit: live: %s\n", s.status().message().c_str());
  }
  void answer(std::int64_t id, const std::string& result, const std::string& reason, double t) {
    t = std::max(t, sent_t_);
    sent_t_ = t;
    if (Status s = link_.answer(id, result, reason, t); !s.ok() && !quiet_)
      std::fprintf(stderr, "adit: live: %s\n", s.message().c_str());
    if (!quiet_)
      std::fprintf(stderr, "adit: live: t = %.1f s: command %lld %s%s%s\n", t, static_cast<long long>(id), result.c_str(),
                   reason.empty() ? "" : ": ", reason.c_str());
  }

  void sendPlan(double t, const map::Polyline& path, const char* reason) {
    console::Plan m;
    m.t = t;
    m.reason = reason;
    m.path = path.points;
    // labels[i] names path[i + 1]: the break points A, B, ... between the start and the goal.
    for (std::size_t i = 0; i + 2 < path.points.size(); ++i) m.labels.push_back(breakPointLabel(i));
    send(m);
  }

  // Clearance from the believed map's distance field at every message (the local layer's own
  // figure is infinite whenever no rock is in its sensing range, which is most of the time):
  // the robot's centre to the nearest rock, less its radius.
  void sendTelemetry(double t, const fusion::Navigator& nav, const local::RobotState& state, const char* status,
                     const std::optional<Vec3>& subgoal) {
    console::Telemetry m;
    m.t = t;
    m.pose = state.position;
    m.velocity = state.velocity;
    m.status = estopped_ ? "estop" : status;
    m.goal = nav.goal();
    m.subgoal = subgoal;
    // A ground robot's centre stands half its height over the floor, which is not rock in the
    // way: its clearance is its footprint's to the rock in its body's band.
    double centre = 0.0, band = std::numeric_limits<double>::infinity();
    nav.read([&](const map::OccupancyMap&, const map::DistanceField& f) {
      if (robot_.ground())
        band = local::bandFootprintClearance(f, robot_, state.position, state.yaw);
      else
        centre = f.distance(state.position);
    });
    // (Rock farther than the band's 3 m range reads as 3 m.)
    m.min_clearance = std::max(0.0, robot_.ground() ? std::min(band, 3.0) : centre - radius_);
    if (robot_.ground()) {
      m.yaw = state.yaw;
      if (robot_.footprint.box) {
        m.body = Vec3(robot_.footprint.length_m, robot_.footprint.width_m, robot_.height_m);
      } else {
        m.body = Vec3(2.0 * robot_.footprint.radius_m, 2.0 * robot_.footprint.radius_m, robot_.height_m);
        m.body_shape = "cylinder";
      }
    }
    m.speed = state.velocity.norm();
    if (speed_ > 0.0) m.period = period_ / speed_;  // mission time paced to the wall clock
    send(m);
  }

  void sendObstacles(double t, const std::vector<map::MovingObstacle>& tracks) {
    console::Obstacles m;
    m.t = t;
    m.rock = std::move(fresh_rock_);
    for (std::size_t i = 0; i < tracks.size(); ++i)
      m.tracks.push_back({"v" + std::to_string(i + 1), tracks[i].position, tracks[i].velocity,
                          tracks[i].shape.boundingRadius()});
    for (console::Obstacles& part : console::splitObstacles(m)) send(std::move(part));
    fresh_rock_.clear();
  }

  // One command between periods: accepted or refused at once; executed at once, or (a goal) on
  // arrival.
  void execute(double t, fusion::Navigator& nav, const console::ReceivedCommand& c) {
    const std::int64_t id = c.id;
    auto refuse = [&](const std::string& why) { answer(id, "refused", why, t); };
    auto done = [&](const std::string& note) {
      answer(id, "accepted", "", t);
      answer(id, "executed", note, t);
    };
    // The e-stop latches: the robot holds (the navigator's pause, velocity set-point zero) and
    // refuses anything that would move it until the e-stop is released; a release does not
    // restart it (the operator resumes, as after any emergency stop).
    if (c.kind == "estop") {
      nav.pause();
      const bool again = estopped_;
      estopped_ = true;
      answer(id, "accepted", "", t);
      answer(id, "executed", again ? "stopped already" : "stopped", t);
      return;
    }
    if (c.kind == "estop_release") {
      if (!estopped_) return refuse("not e-stopped");
      estopped_ = false;
      return done("e-stop released; paused until resumed");
    }
    if (estopped_ && (c.kind == "resume" || c.kind == "goal" || c.kind == "manual" || c.kind == "release"))
      return refuse("e-stopped: release the e-stop first");
    if (c.kind == "pause") {
      nav.pause();
      done("");
    } else if (c.kind == "resume") {
      if (!nav.paused()) return refuse("not paused");
      nav.resume();
      done("");
    } else if (c.kind == "manual") {
      if (Status s = nav.manual(*c.velocity); !s.ok()) return refuse(s.message());
      done("");
    } else if (c.kind == "release") {
      if (!nav.manualControl()) return refuse("not in manual control");
      const Status s = nav.release();
      sendPlan(t, nav.expectedPath(), "replan");
      if (!s.ok()) {
        answer(id, "accepted", "", t);
        return answer(id, "executed", "released, but " + s.message(), t);
      }
      done("replanned from here");
    } else if (c.kind == "goal") {
      if (Status s = nav.setGoal(*c.goal); !s.ok()) return refuse(s.message());
      if (goal_command_) answer(*goal_command_, "refused", "superseded by command " + std::to_string(id), t);
      goal_command_ = id;
      answer(id, "accepted", "", t);
      sendPlan(t, nav.expectedPath(), "goal");
    } else if (c.kind == "block" || c.kind == "reopen") {
      const bool block = c.kind == "block";
      StatusOr<fusion::RoadwayBlockResult> r = block ? nav.blockRoadway(c.roadway) : nav.reopenRoadway(c.roadway);
      if (!r.ok()) return refuse(r.status().message());
      if (r->replanned && !r->no_route) sendPlan(t, nav.expectedPath(), block ? "blocked" : "replan");
      std::string note = std::to_string(r->voxels) + " voxels " + (block ? "closed" : "reopened");
      if (r->no_route) note += "; no route to the goal: " + r->message;
      else if (r->replanned) note += "; replanned";
      else note += "; the expected path does not cross it";
      done(note);
    }
  }

  // --live-hold: paused at the start, the operator's commands executed as they come, until one
  // of them is a resume. Waits for a person, so it polls without a deadline (Ctrl-C ends it).
  void holdUntilResumed(double t, fusion::Navigator& nav, const local::RobotState& state) {
    nav.pause();
    sendTelemetry(t, nav, state, "paused", std::nullopt);
    if (!quiet_) std::fprintf(stderr, "adit: live: holding at the start until the operator resumes\n");
    // Telemetry goes on while the robot waits: a silent robot is a stale one to the console.
    const auto every = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(speed_ > 0.0 ? period_ / speed_ : period_));
    auto next = std::chrono::steady_clock::now() + every;
    while (nav.paused()) {
      for (const console::ReceivedCommand& c : link_.pollCommands()) execute(t, nav, c);
      if (!nav.paused()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (std::chrono::steady_clock::now() >= next) {
        sendTelemetry(t, nav, state, "paused", std::nullopt);
        next += every;
      }
    }
    wall0_ = std::chrono::steady_clock::now() - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                     std::chrono::duration<double>(speed_ > 0.0 ? t / speed_ : 0.0));
  }

  void awaitAcknowledgement(double t) {
    if (link_.flush(lockstep_timeout_s_)) return;
    lockstep_ = false;
    if (!quiet_)
      std::fprintf(stderr, "adit: live: t = %.1f s: the console acknowledged nothing for %.0f s; lockstep off\n", t,
                   lockstep_timeout_s_);
  }

  void pace(double t) {
    if (speed_ <= 0.0) return;
    std::this_thread::sleep_until(wall0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                               std::chrono::duration<double>(t / speed_)));
  }

  console::RobotLink& link_;
  local::RobotLimits robot_;
  double dt_, radius_, speed_, period_;
  bool quiet_, hold_, lockstep_;
  bool estopped_ = false;
  double lockstep_timeout_s_;
  double resolution_ = 0.2;
  std::chrono::steady_clock::time_point wall0_ = std::chrono::steady_clock::now();
  double next_telemetry_ = 0.0;
  double sent_t_ = 0.0;  // the latest t sent
  int collisions_ = 0;
  const char* last_status_ = "following";
  std::set<std::array<double, 3>> sent_rock_;
  std::vector<Vec3> fresh_rock_;
  std::optional<std::int64_t> goal_command_;
};

// Connects the live link before the run; a console that is not there is bad input (exit 2).
StatusOr<std::unique_ptr<console::RobotLink>> connectLive(const SimulateArgs& a, const Scenario& sc) {
  if (!sc.map_path) return invalidArgument(sc.file + ": --live needs a scenario with a map (the console shows it)");
  console::RobotHello hello;
  hello.robot = a.robot_id;
  if (hello.robot.empty()) {
    std::string stem = sc.file.substr(sc.file.find_last_of('/') + 1);
    hello.robot = stem.substr(0, stem.rfind('.'));
  }
  hello.map = sc.map_path->substr(sc.map_path->find_last_of('/') + 1);
  ADIT_ASSIGN_OR_RETURN(hello.map_hash, map::fileContentHash(*sc.map_path));
  hello.radius_m = sc.params.robot.radius_m;
  console::LinkOptions options;
  if (!a.live_token_file.empty()) {
    ADIT_ASSIGN_OR_RETURN(const TokenFile t, readTokenFile(a.live_token_file));
    options.token = t.token;
  }
  return console::RobotLink::connect(a.live, hello, options);
}

nlohmann::ordered_json toJson(const Scenario& sc, const SimulationResult& r) {
  nlohmann::ordered_json j;
  j["scenario"] = sc.name;
  j["method"] = methodName(sc.params.method);
  j["subgoals"] = subgoalModeName(sc.subgoal_mode);
  // Which field ran: the papers' as published (preset paper) or with the terminal phase.
  j["preset"] = paramsPresetName(sc.preset);
  j["terminal_phase"] = sc.params.terminal.enabled;
  j["outcome"] = outcomeName(r.outcome);
  if (!r.message.empty()) j["message"] = r.message;
  if (r.end_cause != EndCause::kNone) j["end_cause"] = endCauseName(r.end_cause);
  j["arrival_time"] = r.arrived() ? nlohmann::ordered_json(us(r.arrival_time_s)) : nlohmann::ordered_json(nullptr);
  j["arrival_tolerance"] = mm(r.arrival_tolerance_m);
  j["path_length"] = mm(r.path_length_m);
  j["min_clearance"] = mmOrNull(r.min_clearance_m);
  j["collisions"] = r.collisions;
  if (r.collisions > 0) j["first_collision"] = {{"t", us(r.first_collision_t_s)}, {"with", r.first_collision_with}};
  j["steps"] = r.steps;
  j["escapes"] = r.escapes;
  j["final_goal_distance"] = mm(r.final_goal_distance_m);
  j["step_time_us"] = {{"p50", tenthUs(r.step_time_p50_us)}, {"p99", tenthUs(r.step_time_p99_us)}};
  j["seed"] = sc.seed;
  auto closest = nlohmann::ordered_json::array();
  for (const ClosestApproach& c : r.closest)
    closest.push_back({{"obstacle", c.name},
                       {"distance", mmOrNull(c.distance_m)},
                       {"t", us(c.t_s)}});
  j["closest_approaches"] = closest;
  const bool subgoals = sc.subgoal_mode != SubgoalMode::kNone;
  if (subgoals) {
    // How the per-period selection went: periods by outcome (optimized, straight, ...) and its time.
    nlohmann::ordered_json kinds = nlohmann::ordered_json::object();
    for (const auto& [kind, n] : r.subgoals.by_kind) kinds[kind] = n;
    j["subgoal_period"] = us(sc.subgoal_period_s);
    j["subgoal_selection"] = {{"periods", r.subgoals.periods},
                              {"outcomes", kinds},
                              {"time_us", {{"mean", tenthUs(r.subgoals.time_mean_us)}, {"max", tenthUs(r.subgoals.time_max_us)}}}};
  }
  auto traj = nlohmann::ordered_json::array();
  for (const TrajectorySample& s : r.trajectory) {
    // t is step x dt: to the microsecond it reads as the step time (52.9, not 52.900000000000006).
    nlohmann::ordered_json sample{{"t", us(s.t_s)}, {"x", mm(s.position.x())}, {"y", mm(s.position.y())},
                                  {"z", mm(s.position.z())}, {"vx", mmPerS(s.velocity.x())},
                                  {"vy", mmPerS(s.velocity.y())}, {"vz", mmPerS(s.velocity.z())},
                                  {"status", stepStatusName(s.status)}};
    if (subgoals) sample["subgoal"] = mmPoint(s.sub_goal);
    if (sc.params.robot.ground()) sample["yaw"] = std::round(s.yaw * 1e4) / 1e4;  // a ground robot's heading [rad]
    traj.push_back(std::move(sample));
  }
  j["trajectory"] = traj;
  return j;
}

// What the navigator adds to the JSON: replans, the world's and the navigator's events, paths.
void addNavigatorJson(nlohmann::ordered_json& j, const Scenario& sc, const sim::NavigatedRun& n) {
  auto pathJson = [](const map::Polyline& p) {
    auto a = nlohmann::ordered_json::array();
    for (const Vec3& q : p.points) a.push_back(mmPoint(q));
    return a;
  };
  j["replans"] = n.replans;
  j["max_replan_time"] = us(n.max_replan_time_s);
  j["max_cycle_time"] = us(n.max_cycle_time_s);
  j["min_fall_clearance"] = mmOrNull(n.min_fall_clearance_m);
  j["end_time"] = us(n.end_time_s);
  j["wall_time"] = us(n.wall_time_s);
  auto events = nlohmann::ordered_json::array();
  for (const ScenarioEvent& e : sc.events)
    if (e.t_s <= n.end_time_s + 1e-9)
      events.push_back({{"t", us(e.t_s)}, {"type", e.type}, {"what", "the ball became rock (true world)"},
                        {"center", mmPoint(e.center)}, {"radius", mm(e.radius_m)}});
  for (const fusion::NavigatorEvent& e : n.events) {
    nlohmann::ordered_json ev{{"t", us(e.t_s)}, {"type", e.type}, {"reason", e.reason}};
    if (e.type != "map_update_failed") ev["replan_time"] = us(e.replan_time_s);
    if (e.refine_time_s > 0.0) ev["refine_time"] = us(e.refine_time_s);
    if (!e.route.empty()) ev["route"] = e.route;
    if (!e.message.empty()) ev["message"] = e.message;
    events.push_back(ev);
  }
  std::stable_sort(events.begin(), events.end(), [](const auto& a, const auto& b) {
    return a["t"].template get<double>() < b["t"].template get<double>();
  });
  j["events"] = events;
  j["initial_path"] = pathJson(n.initial_path);
  j["final_path"] = pathJson(n.final_path);
  if (n.refinement) {
    // The initial expected path before and after the break-point refinement (initial_path is after).
    auto quality = [](const fusion::PathQuality& q) {
      return nlohmann::ordered_json{{"length", mm(q.length_m)},
                                    {"min_clearance", mm(q.min_clearance_m)},
                                    {"mean_clearance", mm(q.mean_clearance_m)},
                                    {"break_points", q.break_points}};
    };
    const fusion::PlanRefinement& f = *n.refinement;
    nlohmann::ordered_json before = quality(f.before);
    before["path"] = pathJson(f.before_path);
    j["refinement"] = {{"outcome", fusion::refineOutcomeName(f.outcome)}, {"message", f.message},
                       {"time", us(f.time_s)},  {"iterations", f.iterations},
                       {"before", before},  {"after", quality(f.after)}};
  }
}

// The run drawn on the map (or open space): static obstacles, moving-obstacle tracks, the
// expected path and the trajectory coloured by time.
// `page`: the animated page's background, which holds only what stands the whole run (map,
// static obstacles, start, goal): the page draws the rest at its time (the trajectory, the paths,
// the falls, the sub-goals, the movers), so that at t it shows only what happened by t. The view
// is the still picture's either way.
// `replanned`: the navigator's last expected path when it differs from the first (drawn dashed).
Figure runFigure(const Scenario& sc, const Environment& env, const SimulationResult& r, bool page,
                 const map::Polyline* replanned = nullptr) {
  TopViewOptions opt;
  // The page's picture is there from t = 0: its title does not give the end away.
  opt.title = sc.name + " (" + methodName(sc.params.method) + ")" + (page ? "" : std::string(": ") + outcomeName(r.outcome));
  map::Aabb box;
  for (const TrajectorySample& s : r.trajectory) box.extend(s.position);
  for (const Vec3& p : sc.expected_path.points) box.extend(p);
  for (const StaticSphere& s : sc.static_obstacles) box.extend(map::Aabb(s.center, s.center).inflated(s.radius));
  const double t_end = r.trajectory.empty() ? 0.0 : r.trajectory.back().t_s;
  // Tracks only near the run: accelerating obstacles can leave for kilometres.
  const map::Aabb near = box.inflated(3.0);
  std::vector<FigureLine> tracks;
  std::vector<FigureDisc> ends;
  for (const NamedObstacle& m : sc.moving_obstacles) {
    FigureLine track;
    for (double t = 0.0; t <= t_end + 1e-9; t += std::max(t_end / 200.0, 0.05))
      if (near.contains(m.obstacle.positionAt(t))) track.points.push_back(m.obstacle.positionAt(t));
    for (const Vec3& p : track.points) box.extend(p);
    if (track.points.size() < 2) continue;
    track.colour = kFigureMoving;
    track.width_px = 1.5;
    track.dashed = true;
    FigureDisc end;
    end.center = track.points.back();  // last position near the run
    end.radius_m = m.obstacle.shape.boundingRadius();
    end.fill = end.stroke = kFigureMoving;
    end.label = m.name;
    if (page) continue;
    tracks.push_back(std::move(track));
    ends.push_back(std::move(end));
  }
  if (env.map()) {
    // A run crosses a small part of a district: draw that part (with a margin for context) so
    // that the robot, the falls and the paths are legible.
    map::Aabb view = box;
    view.extend(sc.start);
    view.extend(sc.goal);
    if (replanned)
      for (const Vec3& p : replanned->points) view.extend(p);
    for (const ScenarioEvent& e : sc.events) view.extend(map::Aabb(e.center, e.center).inflated(e.radius_m));
    const Vec3 size = view.size();
    opt.view_box_m = view.inflated(std::max(10.0, 0.12 * std::max(size.x(), size.y())));
  }
  Figure fig(opt);
  for (FigureLine& l : tracks) fig.addLine(std::move(l));
  for (FigureDisc& d : ends) fig.addDisc(std::move(d));
  if (env.map()) fig.setMap(env.map());
  else fig.setWorldBounds(box.inflated(1.0));
  for (const StaticSphere& s : sc.static_obstacles) {
    FigureDisc d;
    d.center = s.center;
    d.radius_m = s.radius;
    fig.addDisc(d);
  }
  if (page) {
    fig.addMarker({sc.start, MarkerShape::kCircle, kFigureStart, 9, "start", "", 0});
    fig.addMarker({sc.goal, MarkerShape::kSquare, kFigureGoal, 9, "goal", "", 0});
    return fig;
  }
  for (const ScenarioEvent& e : sc.events) {
    FigureDisc d;
    d.center = e.center;
    d.radius_m = e.radius_m;
    d.fill = d.stroke = kFigureBlocked;
    d.label = "roof fall t=" + std::to_string(int(e.t_s)) + " s";
    fig.addDisc(d);
  }
  fig.addLine({sc.expected_path.points, kFigurePath, 2.0, true, {}, "expected path", ""});
  if (replanned) fig.addLine({replanned->points, kFigureMoving, 2.0, true, {}, "replanned path", ""});
  FigureLine traj{{}, kFigureTrajectory, 2.5, false, {}, "trajectory", "time [s]"};
  for (const TrajectorySample& s : r.trajectory) {
    traj.points.push_back(s.position);
    traj.values.push_back(s.t_s);
  }
  if (traj.points.size() >= 2) fig.addLine(traj);
  if (sc.subgoal_mode != SubgoalMode::kNone) {
    // Each period's sub-goal (the samples hold the one in force: a new value is a new selection).
    bool first = true;
    for (std::size_t i = 1; i < r.trajectory.size(); ++i)
      if (r.trajectory[i].sub_goal != r.trajectory[i - 1].sub_goal) {
        fig.addMarker({r.trajectory[i].sub_goal, MarkerShape::kCross, kFigureTrajectory, 5, "",
                       first ? "sub-goals (one per period)" : ""});
        first = false;
      }
  }
  fig.addMarker({sc.start, MarkerShape::kCircle, kFigureStart, 9, "start", "", 0});
  fig.addMarker({sc.goal, MarkerShape::kSquare, kFigureGoal, 9, "goal", "", 0});
  return fig;
}

// The run's events for the page's timeline, in time order: roof falls (with their balls),
// replans (with the path each made), the navigator's other decisions, escapes, the robot getting
// stuck, the first collision, and the end (arrival or the outcome).
std::vector<PageEvent> pageEvents(const Scenario& sc, const SimulationResult& r, const sim::NavigatedRun* nav) {
  std::vector<PageEvent> events;
  const double t_end = r.trajectory.empty() ? 0.0 : r.trajectory.back().t_s;
  char buf[160];
  for (const ScenarioEvent& e : sc.events) {
    if (e.t_s > t_end + 1e-9) continue;
    std::snprintf(buf, sizeof buf, "ball of r = %.1f m at (%.1f, %.1f, %.1f)", e.radius_m, e.center.x(),
                  e.center.y(), e.center.z());
    PageEvent ev{e.t_s, e.type, buf, "", e.center, e.radius_m, {}};
    events.push_back(std::move(ev));
  }
  if (nav) {
    std::vector<bool> used(nav->path_changes.size(), false);
    for (const fusion::NavigatorEvent& e : nav->events) {
      PageEvent ev;
      ev.t_s = e.t_s;
      ev.kind = e.type;
      ev.label = e.reason;
      if (!e.route.empty()) {
        ev.label += ev.label.empty() ? "via " : "; via ";
        for (std::size_t k = 0; k < e.route.size(); ++k) ev.label += (k ? ", " : "") + e.route[k];
      }
      if (!e.message.empty()) ev.label += (ev.label.empty() ? "" : " (") + e.message + (ev.label.empty() ? "" : ")");
      if (e.type == "replan") ev.status = "replanning";
      // The path the cycle made belongs to its event; a no_route's (what is left) is not drawn.
      for (std::size_t k = 0; k < nav->path_changes.size(); ++k)
        if (!used[k] && std::abs(nav->path_changes[k].t_s - e.t_s) < 1e-6) {
          if (e.type == "replan") ev.path = nav->path_changes[k].path.points;
          used[k] = true;
          break;
        }
      events.push_back(std::move(ev));
    }
    // A path change no navigator event names (an operator's): still a new path at its time.
    for (std::size_t k = 0; k < nav->path_changes.size(); ++k)
      if (!used[k])
        events.push_back({nav->path_changes[k].t_s, "replan", "expected path changed", "replanning", Vec3::Zero(), 0.0,
                          nav->path_changes[k].path.points});
  }
  for (double t : r.escape_times_s)
    events.push_back({t, "escape", "no progress: an escape manoeuvre begins", "", Vec3::Zero(), 0.0, {}});
  for (std::size_t i = 1; i < r.trajectory.size(); ++i)
    if (r.trajectory[i].status == StepStatus::kStuck && r.trajectory[i - 1].status != StepStatus::kStuck)
      events.push_back({r.trajectory[i].t_s, "stuck", "no progress after the bounded escapes", "", Vec3::Zero(), 0.0, {}});
  if (r.collisions > 0)
    events.push_back({r.first_collision_t_s, "collision", "with " + r.first_collision_with, "", Vec3::Zero(), 0.0, {}});
  if (!r.trajectory.empty()) {
    const std::string outcome = outcomeName(r.outcome);
    events.push_back({r.arrived() ? r.arrival_time_s : t_end, r.arrived() ? "arrived" : "end",
                      r.arrived() ? "at the goal" : outcome + (r.message.empty() ? "" : ": " + r.message), "",
                      Vec3::Zero(), 0.0, {}});
  }
  std::stable_sort(events.begin(), events.end(), [](const PageEvent& a, const PageEvent& b) { return a.t_s < b.t_s; });
  return events;
}

// The animated page: the figure's standing part as background; the robot, the movers, the paths,
// the falls, the sensed rock and the sub-goals drawn by the page at their times.
Status writePage(const Scenario& sc, const Figure& fig, const SimulationResult& r, const sim::NavigatedRun* nav,
                 const std::string& path) {
  AnimationPageInput in;
  in.title = sc.name + " (" + methodName(sc.params.method) + ")";
  in.robot_radius_m = sc.params.robot.radius_m;
  const local::RobotLimits& robot = sc.params.robot;
  if (robot.ground() && robot.footprint.box) {
    in.robot_length_m = robot.footprint.length_m;
    in.robot_width_m = robot.footprint.width_m;
  }
  for (const NamedObstacle& m : sc.moving_obstacles)
    in.movers.push_back({m.name, m.obstacle.shape.boundingRadius(), kFigureMoving});
  for (const TrajectorySample& s : r.trajectory) {
    PageFrame f{s.t_s, s.position, stepStatusName(s.status), {}};
    if (robot.ground()) f.yaw = s.yaw;
    for (const NamedObstacle& m : sc.moving_obstacles) f.movers.push_back(m.obstacle.positionAt(s.t_s));
    in.frames.push_back(std::move(f));
  }
  in.initial_path = sc.expected_path.points;  // the navigator's initial path for a navigated run
  in.events = pageEvents(sc, r, nav);
  if (nav)
    for (const sim::NavigatedRun::SensedRock& p : nav->sensed) in.sensed.push_back({p.t_s, p.point});
  if (sc.subgoal_mode != SubgoalMode::kNone) {
    // The samples hold the sub-goal in force: a new value is a new selection, made in the period
    // that ended at the sample before.
    for (std::size_t i = 1; i < r.trajectory.size(); ++i)
      if (r.trajectory[i].sub_goal != r.trajectory[i - 1].sub_goal)
        in.subgoals.push_back({r.trajectory[i - 1].t_s, r.trajectory[i].sub_goal});
  }
  char buf[64];
  auto fmt = [&buf](const char* f, double v) {
    std::snprintf(buf, sizeof buf, f, v);
    return std::string(buf);
  };
  in.summary = {{"method", methodName(sc.params.method)},
                {"outcome", outcomeName(r.outcome)},
                {"arrival time", r.arrived() ? fmt("%.1f s", r.arrival_time_s) : "-"},
                {"path length", fmt("%.2f m", r.path_length_m)},
                {"min clearance", std::isfinite(r.min_clearance_m) ? fmt("%.3f m", r.min_clearance_m) : "-"},
                {"collisions", std::to_string(r.collisions)},
                {"step time p50", fmt("%.1f us", r.step_time_p50_us)}};
  return writeAnimationPage(fig, in, path);
}

int runBatch(const SimulateArgs& a);

// An OctoMap, a scan or a mesh handed over as the SCENARIO would fail in the YAML parser on its
// bytes ("unknown escape character"); say what it is and what to run instead. (A survey YAML is
// recognised by the scenario parser itself.)
Status refuseMapAsScenario(const std::string& path) {
  if (path.empty()) return Status();
  const StatusOr<map::MapFormat> format = map::formatFromPath(path);
  const bool octomap = format.ok() && *format != map::MapFormat::kSurveyYaml;
  if (!octomap && !map::isImportFormat(path)) return Status();
  return invalidArgument(path + ": this is a map, not a scenario: name it as `map:` in a scenario, run a batch on it with "
                         "`adit simulate --batch N --map " + path + "`, or plan on it with `adit plan --map " + path + "`");
}

// The JSON to `out` (atomically), or to stdout when `out` is empty.
Status writeJson(const nlohmann::ordered_json& j, const std::string& out) {
  const std::string json = j.dump(2) + "\n";
  if (!out.empty()) return map::writeFileAtomically(out, [&](std::ostream& os) { return bool(os << json); });
  std::fwrite(json.data(), 1, json.size(), stdout);
  return Status();
}

int run(const SimulateArgs& a) {
  if (a.batch_given && !a.replay.empty()) return report(invalidArgument("--replay is one run, not --batch"));
  if (a.batch_given && !a.live.empty()) return report(invalidArgument("--live is one run, not --batch"));
  if (a.batch_given) return runBatch(a);
  PhaseTimes phases;
  if (!a.replay.empty() && !a.scenario.empty())
    return report(invalidArgument("--replay CAMPAIGN:INDEX takes no SCENARIO file (got " + a.scenario + ")"));
  if (a.scenario.empty() && a.replay.empty())
    return report(invalidArgument("a SCENARIO file is required (or --batch N --map M, or --replay CAMPAIGN:INDEX)"));
  if (!a.map.empty() && a.replay.empty())
    return report(invalidArgument("--map goes with --batch or --replay (a scenario names its own map)"));
  // Check the output names before the (possibly long) run.
  for (const std::string* p : {&a.picture}) {
    if (p->empty()) continue;
    const std::string ext = p->size() >= 4 ? p->substr(p->size() - 4) : "";
    if (ext != ".png" && ext != ".svg" && ext != ".PNG" && ext != ".SVG")
      return report(invalidArgument(*p + ": --picture must end in .png or .svg"));
  }
  if (!a.html.empty() && (a.html.size() < 5 || a.html.substr(a.html.size() - 5) != ".html"))
    return report(invalidArgument(a.html + ": --html must end in .html"));
  // Every output writable before the run, so that none is written when another would fail.
  if (Status s = checkOutputPath(a.out, "--out"); !s.ok()) return report(s);
  if (Status s = checkOutputPath(a.picture, "--picture"); !s.ok()) return report(s);
  if (Status s = checkOutputPath(a.html, "--html"); !s.ok()) return report(s);
  if (!(a.live_speed >= 0.0) || !std::isfinite(a.live_speed))
    return report(invalidArgument("--live-speed must be >= 0 (1 real time, 0 as fast as possible)"));
  if (!(a.live_period > 0.0) || !std::isfinite(a.live_period))
    return report(invalidArgument("--live-period must be > 0 s"));
  if (!(a.live_flush >= 0.0) || !std::isfinite(a.live_flush))
    return report(invalidArgument("--live-flush must be >= 0 s"));
  if (!a.live_token_file.empty() && a.live.empty()) return report(invalidArgument("--live-token-file needs --live URL"));
  if ((a.live_hold || a.live_lockstep) && a.live.empty())
    return report(invalidArgument(std::string(a.live_hold ? "--live-hold" : "--live-lockstep") + " needs --live URL"));
  if (Status s = refuseMapAsScenario(a.scenario); !s.ok()) return report(s);
  StatusOr<Scenario> sc = a.replay.empty() ? loadScenario(a.scenario) : replayScenario(a.replay, a.map);
  if (!sc.ok()) return report(sc.status());
  // The run keeps a record of every period (trajectory, then its JSON): refused up front when
  // that cannot fit, instead of growing until the kernel kills the process (t_max 10^6 s at
  // dt 0.1 reached 8.7 GB: 870 B a period, rounded up here).
  const StatusOr<std::uint64_t> budget = memoryBudgetOf(a.max_memory);  // the record's and the map's
  if (!budget.ok()) return report(budget.status());
  {
    constexpr double kRecordBytesPerPeriod = 1024.0;
    const double periods = std::ceil(sc->t_max_s / sc->dt_s) + 1.0;
    char count[32];
    std::snprintf(count, sizeof count, "%.0f", periods);
    const std::string what = sc->file + ": t_max / dt = " + count + " periods: the run's record";
    if (Status s = map::MemoryBudget{*budget}.check(periods * kRecordBytesPerPeriod, what,
                                                    "lower t_max, raise dt, or raise --max-memory");
        !s.ok())
      return report(s);
  }
  if (!a.quiet)
    std::fprintf(stderr, "adit: simulating %s with %s (sub-goals: %s) %s%s\n", sc->name.c_str(),
                 methodName(sc->params.method), subgoalModeName(sc->subgoal_mode), sc->map_path ? "on " : "in open space",
                 sc->map_path ? sc->map_path->c_str() : "");
  // The scenario's map is loaded once: the referee's true world borrows it and the navigator's
  // believed world starts from its copy (loading it twice was most of a short run's wall time).
  phases.mark("scenario");
  std::optional<map::World> world;
  StatusOr<Environment> env = Environment::openSpace();
  if (sc->map_path) {
    StatusOr<map::World> w = loadWorld(*sc->map_path, map::UnknownPolicy::kRock, a.quiet, a.no_cache, *budget);
    if (!w.ok()) return report(w.status());
    world.emplace(std::move(w).value());
    env = Environment::borrow(*world);
    if (!env.ok()) return report(env.status());
    phases.mark("map other");
    phases.splitWorld("map other", world->times());
    // The run queries voxels (the falls, the sensor's rays): their states are read now from the
    // cached bytes, so that the time line names it instead of charging it to the first period.
    if (!world->cacheReport().used.empty()) {
      world->map().prepareVoxelQueries();
      phases.mark("voxel states from cache");
    }
  }
  std::optional<sim::NavigatedRun> nav;
  StatusOr<SimulationResult> r = internalError("not run");
  std::unique_ptr<console::RobotLink> link;
  std::optional<LiveConsole> live;
  bool live_lost = false;
  if (!a.live.empty()) {
    StatusOr<std::unique_ptr<console::RobotLink>> l = connectLive(a, *sc);
    if (!l.ok()) return report(l.status());
    link = std::move(l).value();
    live.emplace(*link, sc->dt_s, sc->params.robot,
                 LiveOptions{a.live_speed, a.live_period, a.live_hold, a.live_lockstep, a.live_flush, a.quiet});
    if (!a.quiet) std::fprintf(stderr, "adit: live: connected to %s\n", a.live.c_str());
  }
  if (sc->needsNavigator() || live) {
    sim::NavigatedOptions options;
    options.refine_plan = !a.no_refine;
    options.refine_replans = a.refine_replans;
    if (live) options.observer = &*live;
    if (world) options.believed = &*world;
    StatusOr<sim::NavigatedRun> n = sim::simulateNavigated(*sc, *env, options);
    if (link) {
      // Bounded wait for the centre to acknowledge everything (the run's end included). What is
      // not acknowledged then is lost with this process: the run fails (exit 1), saying so.
      live_lost = !link->flush(a.live_flush);
      if (live_lost)
        std::fprintf(stderr, "adit: live: %zu messages not acknowledged after %.0f s, lost (%s)\n", link->stats().outbox,
                     a.live_flush, link->stats().last_error.c_str());
      else if (!a.quiet)
        std::fprintf(stderr, "adit: live: %llu messages acknowledged, %llu reconnections\n",
                     static_cast<unsigned long long>(link->stats().acked_seq),
                     static_cast<unsigned long long>(link->stats().connections - 1));
    }
    if (!n.ok()) return report(n.status());
    nav = std::move(n).value();
    r = nav->run;
    phases.mark("simulation");
    phases.split("simulation", "belief+navigator", nav->setup_time_s);
    phases.split("simulation", "planning", nav->initial_plan_time_s);
    // Drawn and exported: the path the run started with.
    sc->expected_path = nav->initial_path;
  } else {
    SimulateOptions options;
    if (sc->subgoal_mode == SubgoalMode::kGaTrustRegion)
      options.subgoals = fusion::subgoalFunction(sc->params, sim::subgoalParamsFor(*sc));
    r = simulate(*sc, *env, options);
    phases.mark("simulation");
  }
  if (!r.ok()) return report(r.status());
  const map::Polyline* replanned = nav && nav->replans > 0 ? &nav->final_path : nullptr;

  nlohmann::ordered_json j = toJson(*sc, *r);
  if (nav) addNavigatorJson(j, *sc, *nav);
  if (Status s = writeJson(stamped("adit.simulate", std::move(j)), a.out); !s.ok()) return report(s);
  if (!a.picture.empty())
    if (Status s = runFigure(*sc, *env, *r, false, replanned).render(a.picture); !s.ok()) return report(s);
  if (!a.html.empty())
    if (Status s = writePage(*sc, runFigure(*sc, *env, *r, true, replanned), *r, nav ? &*nav : nullptr, a.html);
        !s.ok())
      return report(s);
  phases.mark("output");
  if (!a.quiet) {
    if (nav && nav->refinement) {
      const fusion::PlanRefinement& f = *nav->refinement;
      std::fprintf(stderr, "refined expected path (%s, %.3f s): %.2f -> %.2f m, min clearance %.3f -> %.3f m\n",
                   fusion::refineOutcomeName(f.outcome), f.time_s, f.before.length_m, f.after.length_m,
                   f.before.min_clearance_m, f.after.min_clearance_m);
    }
    std::fprintf(stderr, "adit: %s: %s", sc->name.c_str(), outcomeName(r->outcome));
    if (r->arrived()) std::fprintf(stderr, " at t = %.1f s", r->arrival_time_s);
    if (nav) std::fprintf(stderr, ", %d replans (longest %.3f s)", nav->replans, nav->max_replan_time_s);
    std::fprintf(stderr, ", path %.2f m, min clearance %.3f m, %d collisions, %d steps (p50 %.1f us)",
                 r->path_length_m, r->min_clearance_m, r->collisions, r->steps, r->step_time_p50_us);
    if (r->subgoals.periods > 0)
      std::fprintf(stderr, ", %d sub-goal periods (mean %.0f us)", r->subgoals.periods, r->subgoals.time_mean_us);
    std::fputc('\n', stderr);
  }
  const int rc = r->arrived() && !live_lost ? kExitOk : kExitFailure;
  // Freed here, not at exit, so that the time line says what freeing the world costs.
  r = internalError("freed");
  nav.reset();
  env = Environment::openSpace();
  world.reset();
  phases.mark("teardown");
  if (!a.quiet) phases.print();
  return rc;
}

// --- `adit simulate --batch N`: randomized navigated runs on one map (issue 8) ---------------

nlohmann::ordered_json batchSummary(const SimulateArgs& a, const Scenario& base, const std::vector<sim::BatchRunResult>& runs,
                                    double wall_s) {
  nlohmann::ordered_json outcomes;
  for (const char* o : {"arrived", "collision", "stuck", "timeout", "no_route", "hit_by_fall", "hit_by_mover", "error"})
    outcomes[o] = 0;
  int arrived = 0, bad_arrivals = 0, dishonest = 0, replans = 0, runs_replanned = 0;
  std::vector<double> p50, p99, arrival;
  std::map<std::string, std::map<std::string, int>> end_causes;
  for (const sim::BatchRunResult& r : runs) {
    outcomes[r.outcome] = outcomes.value(r.outcome, 0) + 1;
    if (r.end_cause != EndCause::kNone) ++end_causes[r.outcome][endCauseName(r.end_cause)];
    replans += r.replans;
    runs_replanned += r.replans > 0;
    if (r.outcome == "error") continue;
    p50.push_back(r.step_p50_us);
    p99.push_back(r.step_p99_us);
    if (r.outcome != "arrived") continue;
    ++arrived;
    arrival.push_back(r.arrival_time_s);
    bad_arrivals += r.collisions > 0;
    dishonest += !(r.final_goal_distance_m <= r.arrival_tolerance_m);
  }
  const double n = double(runs.size());
  nlohmann::ordered_json j;
  j["map"] = *base.map_path;
  j["runs"] = runs.size();
  j["seed"] = a.seed;
  j["first"] = a.first;
  j["jobs"] = std::min(a.jobs, a.batch);
  j["outcomes"] = outcomes;
  j["success_rate"] = ratio(arrived / n);
  j["collisions_among_arrivals"] = bad_arrivals;
  j["arrivals_beyond_tolerance"] = dishonest;
  j["replans"] = {{"total", replans}, {"runs_with_replans", runs_replanned}, {"mean", ratio(replans / n)}};
  j["no_route"] = outcomes["no_route"];
  j["end_causes"] = end_causes;
  j["arrival_time"] = arrival.empty() ? nlohmann::ordered_json(nullptr)
                                      : nlohmann::ordered_json{{"p50", us(stepTimePercentile(arrival, 0.5))},
                                                               {"p90", us(stepTimePercentile(arrival, 0.9))}};
  // Per-run percentiles only are kept: the median run's median step, the 99th-percentile run's p99.
  j["step_time_us"] = {{"p50", p50.empty() ? 0.0 : tenthUs(stepTimePercentile(p50, 0.5))},
                       {"p99", p99.empty() ? 0.0 : tenthUs(stepTimePercentile(p99, 0.99))}};
  j["wall_time"] = us(wall_s);
  return stamped("adit.simulate.batch", std::move(j));
}

int runBatch(const SimulateArgs& a) {
  if (a.batch < 1) return report(invalidArgument("--batch must be >= 1 (got " + std::to_string(a.batch) + ")"));
  if (a.first < 0 || a.first > std::numeric_limits<int>::max() - a.batch)
    return report(invalidArgument("--first must be >= 0 and --first + --batch must fit an int (got " +
                                  std::to_string(a.first) + ")"));
  if (a.jobs < 1) return report(invalidArgument("--jobs must be >= 1 (got " + std::to_string(a.jobs) + ")"));
  if (!a.picture.empty() || !a.html.empty()) return report(invalidArgument("--picture and --html are for one run, not --batch"));
  const auto wall0 = std::chrono::steady_clock::now();
  StatusOr<BatchSetup> setup = loadBatchSetup(a.scenario, a.map, a.no_cache);
  if (!setup.ok()) return report(setup.status());
  const std::string& map_path = *setup->base.map_path;
  sim::BatchParams bp;
  bp.seed = a.seed;
  bp.t_max_s = a.t_max;
  bp.max_separation_m = a.max_separation;
  if (Status s = bp.validate(); !s.ok()) return report(s);
  // Bad input shows in the first scenario: refuse it before forking.
  if (StatusOr<Scenario> first = sim::makeBatchScenario(setup->base, setup->roadways, setup->truth, bp, 0); !first.ok())
    return report(first.status());
  if (!a.quiet)
    std::fprintf(stderr, "adit: batch of %d runs on %s (seed %llu, %d workers)\n", a.batch, map_path.c_str(),
                 static_cast<unsigned long long>(a.seed), std::min(a.jobs, a.batch));
  ProgressBar bar(a.quiet);
  std::vector<int> indices(std::size_t(a.batch));
  for (int k = 0; k < a.batch; ++k) indices[std::size_t(k)] = a.first + k;
  StatusOr<std::vector<sim::BatchRunResult>> runs = runBatchWorkers(*setup, bp, indices, a.jobs, bar);
  if (!runs.ok()) return report(runs.status());
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  if (!a.csv.empty()) {
    Status s = map::writeFileAtomically(a.csv, [&](std::ostream& os) {
      os << sim::batchCsvHeader() << "\n";
      for (const sim::BatchRunResult& r : *runs) os << sim::batchCsvRow(r) << "\n";
      return bool(os);
    });
    if (!s.ok()) return report(s);
  }
  const nlohmann::ordered_json j = batchSummary(a, setup->base, *runs, wall_s);
  if (Status s = writeJson(j, a.out); !s.ok()) return report(s);
  if (!a.quiet)
    std::fprintf(stderr, "adit: %d runs: success rate %.3f, %d collisions among arrivals, %d errors, %.1f s\n", a.batch,
                 j["success_rate"].get<double>(), j["collisions_among_arrivals"].get<int>(),
                 j["outcomes"]["error"].get<int>(), wall_s);
  // A batch is a valid run; it fails when a run could not be simulated or an arrival collided.
  const bool ok = j["outcomes"]["error"].get<int>() == 0 && j["collisions_among_arrivals"].get<int>() == 0 &&
                  j["arrivals_beyond_tolerance"].get<int>() == 0;
  return ok ? kExitOk : kExitFailure;
}

}  // namespace

void registerSimulateVerb(CLI::App& app, int* rc) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Run a scenario (YAML) through the local planner. JSON on stdout or --out; exit 0 arrived, "
      "1 collision/stuck/timeout/no_route, 2 bad scenario");
  cmd->add_option("SCENARIO", args->scenario, "Scenario file (.yaml); with --batch, optional: its robot and method");
  cmd->add_option("-o,--out", args->out, "Write the JSON (with --batch: the summary) here instead of stdout (atomically)");
  cmd->add_option("--batch", args->batch,
                  "Run N randomized navigated scenarios on --map (start/goal on the roadways, vehicles, roof "
                  "falls); JSON summary; exit 1 if a run errored or an arrival collided");
  cmd->add_option("--map", args->map, "With --batch: the map (a survey .yaml, or a .bt/.ot: roadways from its free space); with --replay: the campaign's map, found elsewhere");
  cmd->add_option("--seed", args->seed, "With --batch: the batch seed (each run's seed derives from it and its index)");
  cmd->add_option("--first", args->first,
                  "With --batch: index of the first run (runs --first .. --first + N - 1; re-runs rows of a table)");
  cmd->add_option("--jobs", args->jobs, "With --batch: worker processes (the table does not depend on it)");
  cmd->add_option("--csv", args->csv, "With --batch: one CSV row per run, written atomically");
  cmd->add_option("--max-separation", args->max_separation,
                  "With --batch: largest straight-line start-goal distance [m] (default 150; at least 20)");
  cmd->add_option("--t-max", args->t_max, "With --batch: simulated-time cap per run [s] (default: from the distance)");
  cmd->add_option("--replay", args->replay,
                  "Re-run scenario INDEX of a campaign (`adit campaign run`) as one navigated run: "
                  "CAMPAIGN:INDEX, CAMPAIGN a campaign directory or shard JSON");
  cmd->add_option("--picture", args->picture, "Top view of the run (.png or .svg)");
  cmd->add_option("--html", args->html, "Animated page of the run (.html, one offline file)");
  cmd->add_flag("--no-refine", args->no_refine,
                "expected_path: plan: keep the global layer's path as planned (no break-point refinement)");
  cmd->add_flag("--refine-replans", args->refine_replans,
                "expected_path: plan: refine every replanned path too (the replan takes longer)");
  cmd->add_option("--live", args->live,
                  "Drive the operations console at URL (ws://HOST:PORT, `adit serve`): telemetry, plans, obstacles, "
                  "events; the operator's commands steer the run. No console reachable: exit 2");
  cmd->add_option("--live-speed", args->live_speed, "With --live: times real time (1 default, 0 as fast as possible)");
  cmd->add_option("--live-period", args->live_period, "With --live: telemetry period of mission time [s] (default 0.1)");
  cmd->add_option("--live-flush", args->live_flush,
                  "With --live: how long the run waits at its end for the console to acknowledge every message "
                  "(default 30 s); unacknowledged messages are lost: exit 1");
  cmd->add_flag("--live-hold", args->live_hold,
                "With --live: wait at the start, paused, until the operator resumes the robot; commands sent "
                "meanwhile act before the first step");
  cmd->add_flag("--live-lockstep", args->live_lockstep,
                "With --live: after each period wait for the console's acknowledgement (at most --live-flush), so "
                "a command answering a message acts in the next period");
  cmd->add_option("--max-memory", args->max_memory,
                  maxMemoryHelp("loading the map, and the run's record (a trajectory sample per period)"));
  cmd->add_option("--robot-id", args->robot_id, "With --live: the robot's id (default: the scenario file's stem)");
  cmd->add_option("--live-token-file", args->live_token_file,
                  "With --live: the robot's credential, a file whose first line is its token (from the console's "
                  "--robot-tokens file, or the operator token file for a single robot)");
  cmd->add_flag("--no-cache", args->no_cache, "Build the map's octree and distance field afresh: neither read nor write the map cache");
  cmd->add_flag("-q,--quiet", args->quiet, "No log on stderr");
  cmd->callback([args, rc, cmd] {
    args->batch_given = cmd->count("--batch") > 0;
    *rc = run(*args);
  });
}

}  // namespace adit::tools
