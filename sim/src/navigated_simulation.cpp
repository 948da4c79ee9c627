// SPDX-License-Identifier: BSD-3-Clause
#include "adit/sim/navigated_simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
#include <sstream>

#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "escape_record.hpp"

namespace adit::sim {

namespace {

using fusion::Navigator;
using fusion::NavigatorCycle;
using fusion::NavigatorParams;
using fusion::NavigatorStatus;
using fusion::SensorScan;

// A roof fall that has happened: its ball, and the voxels of its surface the robot has not
// seen yet. Only the surface can ever be seen (every other fall voxel lies behind it), so the
// believed map learns a shell: as good as the whole ball for planning.
struct SurfaceVoxel {
  Vec3 centre;
  Vec3 normal;  // the sum of its open neighbours' directions
};
struct Fall {
  ScenarioEvent event;
  std::vector<SurfaceVoxel> unseen;
  /// It landed within the robot's stopping distance (a period late, then braking at a_max):
  /// a contact with it is the fall's doing, not the planner's (Outcome::kHitByFall).
  bool on_robot = false;
  double stopped_by_s = 0.0;  ///< when the robot, braking from the landing, has stopped
};

// What the robot's sphere may already overlap the fall by, besides its stopping distance, for the
// contact to count as the fall's (the referee's sub-sampling).
constexpr double kFallContactSlackM = 0.05;

bool inBall(const Vec3& p, const ScenarioEvent& e) { return (p - e.center).norm() <= e.radius_m; }

// The fall's voxels (centres inside the ball that were free roadway in the true map) that touch
// free roadway outside the ball.
// The first contact was with a fall that landed within the robot's stopping distance, before
// the robot could have stopped: the fall nearest to where the robot was then.
bool fallLandedOnRobot(const std::vector<Fall>& falls, const SimulationResult& res) {
  const double t = res.first_collision_t_s;
  const TrajectorySample* at = nullptr;
  for (const TrajectorySample& s : res.trajectory)
    if (s.t_s >= t - 1e-9) {
      at = &s;
      break;
    }
  if (!at || falls.empty()) return false;
  const Fall* nearest = nullptr;
  double best = std::numeric_limits<double>::infinity();
  for (const Fall& f : falls) {
    const double d = (at->position - f.event.center).norm() - f.event.radius_m;
    if (f.event.t_s <= t + 1e-9 && d < best) {
      best = d;
      nearest = &f;
    }
  }
  return nearest && nearest->on_robot && t <= nearest->stopped_by_s + 1e-9;
}

Fall makeFall(const ScenarioEvent& e, const map::OccupancyMap& truth) {
  const double res = truth.resolution();
  Fall f{e, {}};
  const int n = int(std::ceil(e.radius_m / res)) + 1;
  auto centre = [res](double c) { return (std::floor(c / res) + 0.5) * res; };
  const Vec3 c0(centre(e.center.x()), centre(e.center.y()), centre(e.center.z()));
  const Vec3 dirs[6] = {Vec3::UnitX(), -Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitY(), Vec3::UnitZ(), -Vec3::UnitZ()};
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) {
        const Vec3 p = c0 + res * Vec3(i, j, k);
        if (!inBall(p, e) || !truth.isFree(p)) continue;
        Vec3 open = Vec3::Zero();
        for (const Vec3& d : dirs)
          if (const Vec3 q = p + res * d; !inBall(q, e) && truth.isFree(q)) open += d;
        if (open.norm() > 0.0) f.unseen.push_back({p, open});
      }
  return f;
}

// The simulated range sensor: the unseen fall surface within range, facing the robot, with a
// clear line of sight through the true world (the map's rock and every fall, voxel by voxel along
// the ray insertRays() will trace). What it sees moves to `returns`; the buffers are the caller's,
// reused from period to period.
void sense(std::vector<Fall>& falls, const map::OccupancyMap& truth, const Vec3& eye, double range,
           std::vector<Vec3>& returns, std::vector<Vec3>& candidates, std::vector<char>& visible) {
  returns.clear();
  auto opaque = [&falls](const Vec3& c) {
    for (const Fall& f : falls)
      if (inBall(c, f.event)) return true;
    return false;
  };
  auto facing = [&](const SurfaceVoxel& v) {
    const Vec3 to_eye = eye - v.centre;
    return to_eye.norm() <= range && v.normal.dot(to_eye) > 0.0;
  };
  for (Fall& f : falls) {
    if ((f.event.center - eye).norm() - f.event.radius_m > range) continue;
    candidates.clear();
    for (const SurfaceVoxel& v : f.unseen)
      if (facing(v)) candidates.push_back(v.centre);
    if (candidates.empty()) continue;
    truth.lineOfSight(eye, candidates, visible, opaque);
    // The candidates are the facing voxels in order: walk both lists together, keeping the unseen.
    std::size_t c = 0, kept = 0;
    for (const SurfaceVoxel& v : f.unseen) {
      if (facing(v) && visible[c++]) returns.push_back(v.centre);
      else f.unseen[kept++] = v;
    }
    f.unseen.resize(kept);
  }
}

}  // namespace

StatusOr<NavigatedRun> simulateNavigated(const Scenario& scenario, const Environment& truth,
                                         const NavigatedOptions& options) {
  const auto wall0 = std::chrono::steady_clock::now();
  ADIT_RETURN_IF_ERROR(scenario.validate());
  ADIT_ASSIGN_OR_RETURN(const Scenario sc, placeOnFloor(scenario, truth));
  if (!sc.map_path || !truth.map() || !truth.checker())
    return invalidArgument(sc.file + ": map: the navigator needs a map to plan on");
  if (!sc.static_obstacles.empty())
    return invalidArgument(sc.file + ": static_obstacles: not supported with the navigator (write them into the map)");
  const double r = sc.params.robot.radius_m;
  const bool ground = sc.params.robot.ground();
  const double yaw0 = ground ? startYaw(sc) : 0.0;
  ADIT_RETURN_IF_ERROR(checkRunEnds(sc, truth));

  // The believed world: its own copy of the map, sharing nothing with the true one.
  std::optional<map::World> believed;
  if (options.believed && options.believed->path() == *sc.map_path) {
    believed.emplace(options.believed->copy());
  } else {
    ADIT_ASSIGN_OR_RETURN(map::World w, map::World::load(*sc.map_path));
    believed.emplace(std::move(w));
  }
  NavigatorParams np;
  np.local = sc.params;
  np.global.seed = std::uint32_t(sc.seed);
  np.refine_plan = sc.plan_expected_path && options.refine_plan;
  np.refine_replans = options.refine_replans;
  // A simulation must give the same run on any machine under any load: the searches stop on
  // iteration counts (solved: max_iterations; unsolved: ~2 s of an idle machine), and the clock
  // only as a last resort, far beyond them.
  np.global.time_budget_s = 60.0;
  np.global.max_unsolved_iterations = 100000;
  np.subgoals = sc.subgoal_mode == SubgoalMode::kGaTrustRegion;
  np.subgoal = subgoalParamsFor(sc);
  ADIT_ASSIGN_OR_RETURN(Navigator nav, Navigator::create(std::move(*believed), np, sc.goal));

  NavigatedRun out;
  const auto plan0 = std::chrono::steady_clock::now();
  out.setup_time_s = std::chrono::duration<double>(plan0 - wall0).count();
  SimulationResult& res = out.run;
  res.arrival_tolerance_m = sc.params.monitor.arrival_tolerance_m;
  if (sc.plan_expected_path) {
    if (Status s = nav.plan(sc.start); !s.ok()) {
      // No route at all from the start: a valid run that ends at once.
      res.outcome = Outcome::kNoRoute;
      res.message = s.message();
      res.final_goal_distance_m = (sc.start - sc.goal).norm();
      res.trajectory.push_back({0.0, sc.start, Vec3::Zero(), local::StepStatus::kRefused});
      if (options.observer) {
        local::RobotState at_start;
        at_start.position = sc.start;
        options.observer->finished(0.0, nav, at_start, res);
      }
      out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      return out;
    }
  } else {
    ADIT_RETURN_IF_ERROR(nav.setExpectedPath(sc.expected_path));
  }
  out.initial_plan_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - plan0).count();
  out.initial_path = nav.expectedPath();
  out.refinement = nav.initialRefinement();
  NavigatedObserver* const observer = options.observer;
  if (observer) observer->started(nav, out.initial_path);

  const double range = sc.sensor_range_m.value_or(kDefaultSensorRangeM);
  const std::size_t nm = sc.moving_obstacles.size();
  res.closest.resize(nm);
  for (std::size_t i = 0; i < nm; ++i) res.closest[i].name = sc.moving_obstacles[i].name;
  std::vector<map::MovingObstacle> tracks(nm);
  SensorScan scan;
  scan.max_range_m = range;
  std::vector<Vec3> candidates;
  std::vector<char> visible;
  std::vector<Fall> falls;
  std::size_t next_event = 0;
  std::vector<double> cycle_us;
  const auto max_steps = std::size_t(std::ceil(sc.t_max_s / sc.dt_s - 1e-9));

  local::RobotState state;
  state.position = sc.start;
  state.yaw = yaw0;
  double t = 0.0;
  res.trajectory.push_back({0.0, state.position, state.velocity, local::StepStatus::kFollowing, state.position, state.yaw});
  NavigatorStatus last = NavigatorStatus::kDriving;
  EscapeRecord escapes;
  for (std::size_t k = 0; k < max_steps; ++k) {
    // The true world changes; the robot senses what of it is in range.
    while (next_event < sc.events.size() && sc.events[next_event].t_s <= t + 1e-9) {
      falls.push_back(makeFall(sc.events[next_event], *truth.map()));
      {
        const double a_max = sc.params.robot.a_max_mps2, speed = state.velocity.norm();
        const double stop = speed * sc.dt_s + speed * speed / (2.0 * a_max);
        const double gap = (state.position - falls.back().event.center).norm() - falls.back().event.radius_m - r;
        falls.back().on_robot = gap <= stop + kFallContactSlackM;
        falls.back().stopped_by_s = t + sc.dt_s + speed / a_max;
      }
      if (observer) observer->roofFall(sc.events[next_event]);
      ++next_event;
    }
    scan.origin = state.position;
    sense(falls, *truth.map(), state.position, range, scan.returns, candidates, visible);
    for (std::size_t i = 0; i < nm; ++i) {
      const map::MovingObstacle& m = sc.moving_obstacles[i].obstacle;
      tracks[i] = m;
      tracks[i].position = m.positionAt(t);
      tracks[i].velocity = m.velocityAt(t);
    }
    if (observer) observer->beforeCycle(t, nav, state);
    const NavigatorCycle c = nav.cycleWithScan(t, state, scan, tracks, sc.dt_s);
    ++res.steps;
    // Kept for a replay of the run (sense() returns each voxel once: these are all new).
    for (const Vec3& p : scan.returns) out.sensed.push_back({t, p});
    if (c.replanned || c.operator_replanned) out.path_changes.push_back({t, nav.expectedPath()});
    if (c.replanned) out.max_replan_time_s = std::max(out.max_replan_time_s, c.replan_time_s);
    else {
      cycle_us.push_back(c.cycle_time_s * 1e6);
      out.max_cycle_time_s = std::max(out.max_cycle_time_s, c.cycle_time_s);
    }
    escapes.add(c.command.escapes, t, res);
    last = c.status;
    // The operator holding or driving the robot is not an end.
    const bool by_hand = c.status == NavigatorStatus::kPaused || c.status == NavigatorStatus::kManual;
    if (c.status != NavigatorStatus::kDriving && !by_hand) {
      if (c.status != NavigatorStatus::kArrived) res.message = c.command.message;
      break;
    }
    // The robot follows the set-points; the referee samples the period against the true world:
    // the map, and the roof falls that have happened.
    refereePeriod(sc, truth, c.command, t, state, res,
                         [&](const Vec3& p, double, double& d, std::string& what) {
                           for (const Fall& f : falls) {
                             const double df = std::max(0.0, (p - f.event.center).norm() - f.event.radius_m - r);
                             out.min_fall_clearance_m = std::min(out.min_fall_clearance_m, df);
                             if (df < d) { d = df; what = "roof fall"; }
                           }
                         });
    t = double(k + 1) * sc.dt_s;
    res.trajectory.push_back({t, state.position, state.velocity, c.command.status, c.subgoal.value_or(c.command.sub_goal), state.yaw});
    if (observer) observer->afterCycle(double(k) * sc.dt_s, nav, c, state, scan, tracks, res);
  }
  // The goal the navigator had at the end: the scenario's unless an operator gave another.
  res.final_goal_distance_m = (state.position - nav.goal()).norm();
  res.step_time_p50_us = stepTimePercentile(cycle_us, 0.5);
  res.step_time_p99_us = stepTimePercentile(cycle_us, 0.99);
  out.replans = nav.replans();
  res.subgoals = nav.subgoalStats();
  out.events = nav.events();
  out.final_path = nav.expectedPath();
  out.end_time_s = t;
  // The verdict is the referee's.
  if (collisionVerdict(res)) {
    if (res.first_collision_with == "roof fall" && fallLandedOnRobot(falls, res)) {
      res.outcome = Outcome::kHitByFall;
      std::ostringstream os;
      os << "a roof fall landed within the robot's stopping distance: contact at t = " << res.first_collision_t_s
         << " s (" << res.collisions << " periods in contact)";
      res.message = os.str();
    }
  } else if (last == NavigatorStatus::kArrived && res.final_goal_distance_m <= res.arrival_tolerance_m) {
    res.outcome = Outcome::kArrived;
    res.arrival_time_s = t;
  } else if (last == NavigatorStatus::kNoRoute) {
    res.outcome = Outcome::kNoRoute;
    if (!out.events.empty()) res.message = out.events.back().message;
  } else if (last == NavigatorStatus::kStuck || last == NavigatorStatus::kRefused) {
    res.outcome = Outcome::kStuck;
  } else {
    res.outcome = Outcome::kTimeout;
    res.message = "t_max reached";
  }
  // The last expected path was made at the last path change (the start's plan otherwise).
  const double path_made_at = out.path_changes.empty() ? 0.0 : out.path_changes.back().t_s;
  res.end_cause = endCause(sc, res.outcome, res.final_goal_distance_m, path_made_at, out.final_path.length());
  if (observer) observer->finished(t, nav, state, res);
  out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return out;
}

}  // namespace adit::sim
