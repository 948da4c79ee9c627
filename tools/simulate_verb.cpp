// SPDX-License-Identifier: BSD-3-Clause
// `adit simulate SCENARIO.yaml`: run a scenario through the local planner and report the run.
// Thin: load, call adit::local::simulate, write JSON / picture / page.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>

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

// The run drawn on the map (or open space): static obstacles, moving-obstacle tracks, the
// expected path and the trajectory coloured by time.
// `mover_ends` marks where each mover was last seen near the run (the still picture); the page
// animates the movers itself and leaves them out.
Figure runFigure(const Scenario& sc, const Environment& env, const SimulationResult& r, bool mover_ends) {
  TopViewOptions opt;
  opt.title = sc.name + " (" + methodName(sc.params.method) + "): " + outcomeName(r.outcome);
  Figure fig(opt);
  map::Aabb box;
  for (const TrajectorySample& s : r.trajectory) box.extend(s.position);
  for (const Vec3& p : sc.expected_path.points) box.extend(p);
  for (const StaticSphere& s : sc.static_obstacles) box.extend(map::Aabb(s.center, s.center).inflated(s.radius));
  const double t_end = r.trajectory.empty() ? 0.0 : r.trajectory.back().t_s;
  // Tracks only near the run: accelerating obstacles can leave for kilometres.
  const map::Aabb near = box.inflated(3.0);
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
    fig.addLine(std::move(track));
    end.radius_m = m.obstacle.shape.boundingRadius();
    end.fill = end.stroke = kFigureMoving;
    end.label = m.name;
    if (mover_ends) fig.addDisc(end);
  }
  if (env.map()) fig.setMap(env.map());
  else fig.setWorldBounds(box.inflated(1.0));
  for (const StaticSphere& s : sc.static_obstacles) {
    FigureDisc d;
    d.center = s.center;
    d.radius_m = s.radius;
    fig.addDisc(d);
  }
  fig.addLine({sc.expected_path.points, kFigurePath, 2.0, true, {}, "expected path", ""});
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
  StatusOr<SimulationResult> r = simulate(*sc, *env);
  if (!r.ok()) return report(r.status());

  const std::string json = toJson(*sc, *r).dump(2) + "\n";
  if (!a.out.empty()) {
    Status s = map::writeFileAtomically(a.out, [&](std::ostream& os) { return bool(os << json); });
    if (!s.ok()) return report(s);
  } else {
    std::fwrite(json.data(), 1, json.size(), stdout);
  }
  if (!a.picture.empty())
    if (Status s = runFigure(*sc, *env, *r, true).render(a.picture); !s.ok()) return report(s);
  if (!a.html.empty())
    if (Status s = writePage(*sc, runFigure(*sc, *env, *r, false), *r, a.html); !s.ok()) return report(s);
  if (!a.quiet) {
    std::fprintf(stderr, "adit: %s: %s", sc->name.c_str(), outcomeName(r->outcome));
    if (r->arrived()) std::fprintf(stderr, " at t = %.1f s", r->arrival_time_s);
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
      "1 collision/stuck/timeout, 2 bad scenario");
  cmd->add_option("SCENARIO", args->scenario, "Scenario file (.yaml)")->required();
  cmd->add_option("--out", args->out, "Write the JSON here instead of stdout (atomically)");
  cmd->add_option("--picture", args->picture, "Top view of the run (.png or .svg)");
  cmd->add_option("--html", args->html, "Animated page of the run (.html, one offline file)");
  cmd->add_flag("-q,--quiet", args->quiet, "No log on stderr");
  cmd->callback([args, rc] { *rc = run(*args); });
}

}  // namespace adit::tools
