// SPDX-License-Identifier: BSD-3-Clause
// `adit simulate SCENARIO.yaml`: run a scenario through the local planner and report the run.
// Thin: load, call adit::local::simulate (or adit::fusion::simulateNavigated for scenarios with
// `expected_path: plan`, `robot.sensor_range` or `events`), write JSON / picture / page.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <optional>
#include <iostream>

#include "adit/fusion/navigated_simulation.hpp"
#include "adit/local/simulator.hpp"
#include "adit/map/map_io.hpp"
#include "common/animation_page.hpp"
#include "common/cli.hpp"
#include "common/figure.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using namespace adit::local;
using adit::map::Vec3;

struct SimulateArgs {
  std::string scenario;
  std::string out;
  std::string picture;
  std::string html;
  bool quiet = false;
};

nlohmann::ordered_json toJson(const Scenario& sc, const SimulationResult& r) {
  nlohmann::ordered_json j;
  j["scenario"] = sc.name;
  j["method"] = methodName(sc.params.method);
  j["outcome"] = outcomeName(r.outcome);
  if (!r.message.empty()) j["message"] = r.message;
  j["arrival_time"] = r.arrived() ? nlohmann::ordered_json(r.arrival_time_s) : nlohmann::ordered_json(nullptr);
  j["arrival_tolerance"] = r.arrival_tolerance_m;
  j["path_length"] = r.path_length_m;
  j["min_clearance"] = std::isfinite(r.min_clearance_m) ? nlohmann::ordered_json(r.min_clearance_m)
                                                        : nlohmann::ordered_json(nullptr);
  j["collisions"] = r.collisions;
  if (r.collisions > 0) j["first_collision"] = {{"t", r.first_collision_t_s}, {"with", r.first_collision_with}};
  j["steps"] = r.steps;
  j["escapes"] = r.escapes;
  j["final_goal_distance"] = r.final_goal_distance_m;
  j["step_time_us"] = {{"p50", r.step_time_p50_us}, {"p99", r.step_time_p99_us}};
  j["seed"] = sc.seed;
  auto closest = nlohmann::ordered_json::array();
  for (const ClosestApproach& c : r.closest)
    closest.push_back({{"obstacle", c.name},
                       {"distance", std::isfinite(c.distance_m) ? nlohmann::ordered_json(c.distance_m) : nlohmann::ordered_json(nullptr)},
                       {"t", c.t_s}});
  j["closest_approaches"] = closest;
  auto traj = nlohmann::ordered_json::array();
  for (const TrajectorySample& s : r.trajectory)
    traj.push_back({{"t", s.t_s}, {"x", s.position.x()}, {"y", s.position.y()}, {"z", s.position.z()},
                    {"vx", s.velocity.x()}, {"vy", s.velocity.y()}, {"vz", s.velocity.z()},
                    {"status", stepStatusName(s.status)}});
  j["trajectory"] = traj;
  return j;
}

// What the navigator adds to the JSON: replans, the world's and the navigator's events, paths.
void addNavigatorJson(nlohmann::ordered_json& j, const Scenario& sc, const fusion::NavigatedRun& n) {
  auto pathJson = [](const map::Polyline& p) {
    auto a = nlohmann::ordered_json::array();
    for (const Vec3& q : p.points) a.push_back({q.x(), q.y(), q.z()});
    return a;
  };
  j["replans"] = n.replans;
  j["max_replan_time"] = n.max_replan_time_s;
  j["max_cycle_time"] = n.max_cycle_time_s;
  j["min_fall_clearance"] = std::isfinite(n.min_fall_clearance_m) ? nlohmann::ordered_json(n.min_fall_clearance_m)
                                                                  : nlohmann::ordered_json(nullptr);
  j["end_time"] = n.end_time_s;
  j["wall_time"] = n.wall_time_s;
  auto events = nlohmann::ordered_json::array();
  for (const ScenarioEvent& e : sc.events)
    if (e.t_s <= n.end_time_s + 1e-9)
      events.push_back({{"t", e.t_s}, {"type", e.type}, {"what", "the ball became rock (true world)"},
                        {"center", {e.center.x(), e.center.y(), e.center.z()}}, {"radius", e.radius_m}});
  for (const fusion::NavigatorEvent& e : n.events) {
    nlohmann::ordered_json ev{{"t", e.t_s}, {"type", e.type}, {"reason", e.reason}};
    if (e.type != "map_update_failed") ev["replan_time"] = e.replan_time_s;
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
}

// The run drawn on the map (or open space): static obstacles, moving-obstacle tracks, the
// expected path and the trajectory coloured by time.
// `mover_ends` marks where each mover was last seen near the run (the still picture); the page
// animates the movers itself and leaves them out.
// `replanned`: the navigator's last expected path when it differs from the first (drawn dashed).
Figure runFigure(const Scenario& sc, const Environment& env, const SimulationResult& r, bool mover_ends,
                 const map::Polyline* replanned = nullptr) {
  TopViewOptions opt;
  opt.title = sc.name + " (" + methodName(sc.params.method) + "): " + outcomeName(r.outcome);
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
    tracks.push_back(std::move(track));
    if (mover_ends) ends.push_back(std::move(end));
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
  fig.addMarker({sc.start, MarkerShape::kCircle, kFigureStart, 9, "start", ""});
  fig.addMarker({sc.goal, MarkerShape::kSquare, kFigureGoal, 9, "goal", ""});
  return fig;
}

// The animated page: the same figure as background, the robot and the movers per period.
Status writePage(const Scenario& sc, const Figure& fig, const SimulationResult& r, const std::string& path) {
  AnimationPageInput in;
  in.title = sc.name + " (" + methodName(sc.params.method) + ")";
  in.robot_radius_m = sc.params.robot.radius_m;
  for (const NamedObstacle& m : sc.moving_obstacles)
    in.movers.push_back({m.name, m.obstacle.shape.boundingRadius(), kFigureMoving});
  for (const TrajectorySample& s : r.trajectory) {
    PageFrame f{s.t_s, s.position, stepStatusName(s.status), {}};
    for (const NamedObstacle& m : sc.moving_obstacles) f.movers.push_back(m.obstacle.positionAt(s.t_s));
    in.frames.push_back(std::move(f));
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

int run(const SimulateArgs& a) {
  // Check the output names before the (possibly long) run.
  for (const std::string* p : {&a.picture}) {
    if (p->empty()) continue;
    const std::string ext = p->size() >= 4 ? p->substr(p->size() - 4) : "";
    if (ext != ".png" && ext != ".svg" && ext != ".PNG" && ext != ".SVG")
      return report(invalidArgument(*p + ": --picture must end in .png or .svg"));
  }
  if (!a.html.empty() && (a.html.size() < 5 || a.html.substr(a.html.size() - 5) != ".html"))
    return report(invalidArgument(a.html + ": --html must end in .html"));
  StatusOr<Scenario> sc = loadScenario(a.scenario);
  if (!sc.ok()) return report(sc.status());
  if (!a.quiet) std::fprintf(stderr, "adit: simulating %s with %s\n", sc->name.c_str(), methodName(sc->params.method));
  StatusOr<Environment> env = Environment::load(*sc);
  if (!env.ok()) return report(env.status());
  std::optional<fusion::NavigatedRun> nav;
  StatusOr<SimulationResult> r = internalError("not run");
  if (sc->needsNavigator()) {
    StatusOr<fusion::NavigatedRun> n = fusion::simulateNavigated(*sc, *env);
    if (!n.ok()) return report(n.status());
    nav = std::move(n).value();
    r = nav->run;
    // Drawn and exported: the path the run started with.
    sc->expected_path = nav->initial_path;
  } else {
    r = simulate(*sc, *env);
  }
  if (!r.ok()) return report(r.status());
  const map::Polyline* replanned = nav && nav->replans > 0 ? &nav->final_path : nullptr;

  nlohmann::ordered_json j = toJson(*sc, *r);
  if (nav) addNavigatorJson(j, *sc, *nav);
  const std::string json = j.dump(2) + "\n";
  if (!a.out.empty()) {
    Status s = map::writeFileAtomically(a.out, [&](std::ostream& os) { return bool(os << json); });
    if (!s.ok()) return report(s);
  } else {
    std::fwrite(json.data(), 1, json.size(), stdout);
  }
  if (!a.picture.empty())
    if (Status s = runFigure(*sc, *env, *r, true, replanned).render(a.picture); !s.ok()) return report(s);
  if (!a.html.empty())
    if (Status s = writePage(*sc, runFigure(*sc, *env, *r, false, replanned), *r, a.html); !s.ok()) return report(s);
  if (!a.quiet) {
    std::fprintf(stderr, "adit: %s: %s", sc->name.c_str(), outcomeName(r->outcome));
    if (r->arrived()) std::fprintf(stderr, " at t = %.1f s", r->arrival_time_s);
    if (nav) std::fprintf(stderr, ", %d replans (longest %.3f s)", nav->replans, nav->max_replan_time_s);
    std::fprintf(stderr, ", path %.2f m, min clearance %.3f m, %d collisions, %d steps (p50 %.1f us)\n",
                 r->path_length_m, r->min_clearance_m, r->collisions, r->steps, r->step_time_p50_us);
  }
  return r->arrived() ? kExitOk : kExitFailure;
}

}  // namespace

void registerSimulateVerb(CLI::App& app, int* rc) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Run a scenario (YAML) through the local planner. JSON on stdout or --out; exit 0 arrived, "
      "1 collision/stuck/timeout/no_route, 2 bad scenario");
  cmd->add_option("SCENARIO", args->scenario, "Scenario file (.yaml)")->required();
  cmd->add_option("--out", args->out, "Write the JSON here instead of stdout (atomically)");
  cmd->add_option("--picture", args->picture, "Top view of the run (.png or .svg)");
  cmd->add_option("--html", args->html, "Animated page of the run (.html, one offline file)");
  cmd->add_flag("-q,--quiet", args->quiet, "No log on stderr");
  cmd->callback([args, rc] { *rc = run(*args); });
}

}  // namespace adit::tools
