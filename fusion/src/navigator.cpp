// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/navigator.hpp"

#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <sstream>

#include "adit/map/occupancy_map.hpp"

namespace adit::fusion {

using map::allFinite;

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string pointText(const Vec3& p) {
  std::ostringstream os;
  os.precision(1);
  os << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return os.str();
}

}  // namespace

Status NavigatorParams::validate() const {
  ADIT_RETURN_IF_ERROR(global.validate());
  ADIT_RETURN_IF_ERROR(local.validate());
  if (max_stuck_replans < 0) return invalidArgument("max_stuck_replans: must be >= 0");
  if (!(replan_back_off_m >= 0.0 && replan_back_off_m <= 10.0))
    return invalidArgument("replan_back_off_m: must be in [0, 10] m");
  if (subgoals) ADIT_RETURN_IF_ERROR(subgoal.validate());
  return {};
}

const char* navigatorStatusName(NavigatorStatus s) {
  switch (s) {
    case NavigatorStatus::kDriving: return "driving";
    case NavigatorStatus::kArrived: return "arrived";
    case NavigatorStatus::kStuck: return "stuck";
    case NavigatorStatus::kNoRoute: return "no_route";
    case NavigatorStatus::kRefused: return "refused";
    case NavigatorStatus::kPaused: return "paused";
    case NavigatorStatus::kManual: return "manual";
  }
  return "?";
}

const char* consoleStatusName(const NavigatorCycle& c) {
  switch (c.status) {
    case NavigatorStatus::kPaused: return "paused";
    case NavigatorStatus::kManual: return "manual";
    case NavigatorStatus::kArrived: return "arrived";
    case NavigatorStatus::kNoRoute: return "no_route";
    case NavigatorStatus::kStuck:
    case NavigatorStatus::kRefused: return "stuck";
    case NavigatorStatus::kDriving: break;
  }
  if (c.replanned || c.operator_replanned) return "replanning";
  switch (c.command.status) {
    case local::StepStatus::kYielding: return "yielding";
    case local::StepStatus::kDetouring: return "detouring";
    default: return "following";
  }
}

struct Navigator::Impl {
  explicit Impl(map::World w) : world(std::move(w)), loaded(world.loaded()), field(&world.field()) {}
  map::World world;
  map::LoadedMap& loaded;      // world's, by their old names
  map::DistanceField* field;
  std::optional<global::GlobalPlanner> global;
  std::optional<local::LocalPlanner> local;
  NavigatorParams params;
  Vec3 goal = Vec3::Zero();
  map::Polyline path;
  std::vector<NavigatorEvent> events;
  std::vector<Vec3> fresh;  // sensed points new to the map (reused between cycles)
  std::optional<PlanRefinement> initial_refinement;
  double last_refine_time_s = 0.0;  // of the latest planFrom()
  int replans = 0;
  int stuck_replans = 0;
  bool no_route = false;
  mutable std::shared_mutex mutex;
  // Sub-goal selection (params.subgoals): when the next is due, and what the last one was for.
  double next_selection_s = -std::numeric_limits<double>::infinity();
  std::size_t selected_segment = 0;
  std::vector<Vec3> selected_path;
  local::SubgoalStats subgoal_stats;
  std::optional<Vec3> subgoal;  // in force
  // Operator commands (issue 11).
  Vec3 position = Vec3::Zero();  // of the last cycle, or plan()'s start: where operator replans start
  double last_t_s = 0.0;
  bool paused = false;
  bool manual = false;
  Vec3 manual_velocity = Vec3::Zero();
  bool operator_replanned = false;  // reported by the next cycle
  std::map<std::string, std::vector<Vec3>> blocks;  // roadway -> the voxel centres it made rock

  // An operator command's replan from the robot's position; caller holds the exclusive lock.
  Status operatorReplan(const std::string& reason, bool refine) {
    const auto r0 = std::chrono::steady_clock::now();
    StatusOr<global::GlobalPlanResult> r = planFrom(position, refine, true);
    ++replans;
    if (!r.ok()) {
      events.push_back({last_t_s, "no_route", reason, secondsSince(r0), {}, r.status().message()});
      return r.status();
    }
    events.push_back({last_t_s, "replan", reason, secondsSince(r0), r->route, "", last_refine_time_s});
    operator_replanned = true;
    no_route = false;
    stuck_replans = 0;
    return {};
  }

  // The voxels an operator's block of roadway `name` makes rock: a survey roadway's middle
  // cross-section, or, on a map without a survey, the middle slice of the free-space graph's
  // passage of that name (passage-N, as `adit map graph` shows them).
  StatusOr<std::vector<Vec3>> blockVoxels(const std::string& name) const {
    if (loaded.survey) {
      ADIT_ASSIGN_OR_RETURN(const map::SurveyRoadway* rw, roadway(name));
      return middleSection(*rw);
    }
    const global::RoadwayGraph& g = global->graph();
    for (std::size_t e = 0; e < g.edges().size(); ++e)
      if (g.edges()[e].roadway == name) {
        std::vector<Vec3> out;
        for (const Vec3& p : g.passageSlice(int(e)))
          if (loaded.map.state(p) == map::VoxelState::kFree) out.push_back(p);
        return out;
      }
    return notFound("unknown passage '" + name + "' (the map has no survey: its roadways are the passages of the "
                    "free-space graph, passage-1 to passage-" + std::to_string(g.edges().size()) + ")");
  }

  // The survey roadway called `name`, or an error listing the known names.
  StatusOr<const map::SurveyRoadway*> roadway(const std::string& name) const {
    if (!loaded.survey) return failedPrecondition("roadway '" + name + "': the map has no survey, so no roadway names");
    std::string known;
    for (const map::SurveyRoadway& r : loaded.survey->roadways) {
      if (r.name == name) return &r;
      known += (known.empty() ? "" : ", ") + r.name;
    }
    return notFound("unknown roadway '" + name + "'; known: " + known);
  }

  // The free voxels (centres) of the roadway's middle cross-section: a slab two voxels thick
  // across the section grown by a voxel all round.
  std::vector<Vec3> middleSection(const map::SurveyRoadway& rw) const {
    const map::SurveyNetwork& net = *loaded.survey;
    const map::Polyline cl = net.centreline(rw);
    const map::CrossSection& section = net.sections.at(rw.section);
    double half_length = 0.0;
    for (std::size_t i = 0; i + 1 < cl.points.size(); ++i) half_length += (cl.points[i + 1] - cl.points[i]).norm();
    half_length *= 0.5;
    Vec3 mid = cl.points.front(), t = Vec3::UnitX();
    for (std::size_t i = 0; i + 1 < cl.points.size(); ++i) {
      const Vec3 a = cl.points[i], b = cl.points[i + 1];
      const double len = (b - a).norm();
      if (len <= 0.0) continue;
      t = (b - a) / len;
      mid = a + t * std::min(half_length, len);
      if (half_length <= len) break;
      half_length -= len;
    }
    const Vec3 n = Vec3::UnitZ().cross(t).normalized();  // survey segments are never vertical
    const Vec3 up = t.cross(n).normalized();
    const double res = loaded.map.resolution(), height = section.height();
    const double reach = 0.5 * section.maxWidth() + height + 2.0 * res;
    std::vector<Vec3> out;
    auto first = [&](double c) { return std::floor((c - reach) / res); };
    for (double i = first(mid.x()); (i + 0.5) * res <= mid.x() + reach; ++i)
      for (double j = first(mid.y()); (j + 0.5) * res <= mid.y() + reach; ++j)
        for (double k = first(mid.z()); (k + 0.5) * res <= mid.z() + reach; ++k) {
          const Vec3 p((i + 0.5) * res, (j + 0.5) * res, (k + 0.5) * res);
          const Vec3 d = p - mid;
          if (std::abs(d.dot(t)) > res) continue;
          const double v = d.dot(up);
          if (v < -res || v > height + res) continue;
          if (std::abs(d.dot(n)) > section.halfWidthAt(std::clamp(v, 0.0, height)) + res) continue;
          if (loaded.map.state(p) == map::VoxelState::kFree) out.push_back(p);
        }
    return out;
  }

  // Writes `voxels` as `state` and makes the field exact again; on a failed field update the
  // voxels are put back, so nothing changed. Returns the changed box (inflated by a voxel).
  StatusOr<map::Aabb> writeVoxels(const std::vector<Vec3>& voxels, map::VoxelState state, map::VoxelState undo) {
    map::MapChange change;
    ADIT_RETURN_IF_ERROR(loaded.map.setVoxels(voxels, state, &change));
    const map::Aabb box = change.box.inflated(field->resolution());
    if (Status s = field->update(loaded.map, box); !s.ok()) {
      (void)loaded.map.setVoxels(voxels, undo);
      (void)field->update(loaded.map, box);
      return s;
    }
    global->mapChanged(box);
    return box;
  }

  // Hands the local planner a new sub-goal when a period starts, the robot moved on to the next
  // segment, or the expected path is not the one the last sub-goal was chosen on (a replan).
  void chooseSubgoal(double t_s, const local::RobotState& state, const std::vector<map::MovingObstacle>& tracks) {
    if (!params.subgoals) return;
    const std::size_t seg = local->currentSegment();
    if (t_s < next_selection_s - 1e-9 && seg == selected_segment && selected_path == path.points) return;
    selected_segment = seg;
    selected_path = path.points;
    next_selection_s = t_s + params.subgoal.t0_s;
    const std::size_t n = path.points.size();
    const Vec3 a = n >= 2 ? path.points[std::min(seg, n - 2)] : path.points.back();
    const Vec3 b = n >= 2 ? path.points[std::min(seg, n - 2) + 1] : path.points.back();
    const auto s0 = std::chrono::steady_clock::now();
    const local::SubgoalPick pick = pickSubgoal(state, a, b, &tracks, nullptr, &*field, params.local, params.subgoal);
    subgoal_stats.add(pick.kind, secondsSince(s0) * 1e6);
    subgoal = pick.point;
    if (pick.point) local->setSubgoal(pick.aim);
    else local->clearSubgoal();
  }

  // Global plan from `from`, refined if `refine`; fills `path` or says why not. Caller holds the
  // exclusive lock.
  // `robot_there`: `from` is where the robot stands (a replan), not a start someone chose; one
  // inside the margin is backed off from rather than refused.
  StatusOr<global::GlobalPlanResult> planFrom(const Vec3& from, bool refine, bool robot_there) {
    last_refine_time_s = 0.0;
    global::GlobalPlanResult r = global->plan(from, goal);
    std::optional<Vec3> backed;
    if (!r.solved() && robot_there && r.outcome == global::GlobalPlanOutcome::kStartInRock &&
        params.replan_back_off_m > 0.0) {
      backed = global->backOff(from, params.replan_back_off_m);
      if (backed) r = global->plan(*backed, goal);
    }
    if (!r.solved()) {
      return failedPrecondition(std::string("no route from ") + pointText(from) + " to the goal: " + r.message);
    }
    if (refine) {
      PlanRefinement ref = refinePlan(*global, *field, &r);
      last_refine_time_s = ref.time_s;
      if (!initial_refinement) initial_refinement = std::move(ref);
    }
    path = r.path;
    if (backed && (path.points.empty() || (path.points.front() - from).norm() > 1e-9))
      path.points.insert(path.points.begin(), from);
    local->reset();
    return r;
  }

  // The first sample of the remaining path (from the robot's nearest segment on) closer to rock
  // than the robot's radius, within `window` grown by the radius.
  std::optional<Vec3> blockedAt(const Vec3& robot, const map::Aabb& window) const {
    const double r = params.local.robot.radius_m;
    const map::Aabb near = window.inflated(r + field->resolution());
    const double lift = params.local.robot.probeLift(field->resolution());  // a ground robot's sphere
    std::size_t first = 0;
    path.nearestPoint(robot, &first);
    const double step = 0.5 * field->resolution();
    for (std::size_t i = first; i + 1 < path.points.size(); ++i) {
      const Vec3 a = path.points[i], b = path.points[i + 1];
      const double len = (b - a).norm();
      const int n = std::max(1, int(std::ceil(len / step)));
      for (int k = 0; k <= n; ++k) {
        const Vec3 p = a + (b - a) * (double(k) / double(n));
        if (near.contains(p) && field->distance(p + Vec3(0, 0, lift)) < r) return p;
      }
    }
    return std::nullopt;
  }
};

Navigator::Navigator(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Navigator::Navigator(Navigator&&) noexcept = default;
Navigator& Navigator::operator=(Navigator&&) noexcept = default;
Navigator::~Navigator() = default;

StatusOr<Navigator> Navigator::create(map::LoadedMap loaded, const NavigatorParams& params, const Vec3& goal) {
  ADIT_ASSIGN_OR_RETURN(map::World w, map::World::build(std::move(loaded)));
  return create(std::move(w), params, goal);
}

StatusOr<Navigator> Navigator::create(map::LoadedMap loaded, map::DistanceField field, const NavigatorParams& params,
                                      const Vec3& goal) {
  StatusOr<map::World> w = map::World::fromParts(std::move(loaded), std::move(field));
  if (!w.ok()) return invalidArgument("navigator: " + w.status().message());
  return create(std::move(w).value(), params, goal);
}

StatusOr<Navigator> Navigator::create(map::World world, const NavigatorParams& params, const Vec3& goal) {
  NavigatorParams p = params;
  // One robot for both layers: the local description decides the global planner's shape and mode.
  const local::RobotLimits& rb = p.local.robot;
  if (rb.ground()) {
    p.global.mode = global::PlanMode::kGround;
    p.global.robot = rb.footprint.box ? map::RobotShape::box(Vec3(rb.footprint.length_m, rb.footprint.width_m, rb.height_m))
                                      : map::RobotShape::cylinder(rb.footprint.radius_m, rb.height_m);
    p.global.max_slope_deg = rb.max_slope_deg;
  } else {
    p.global.robot = map::RobotShape::sphere(rb.radius_m);
  }
  ADIT_RETURN_IF_ERROR(p.validate());
  if (!allFinite(goal)) return invalidArgument("navigator: goal is not finite");
  auto impl = std::make_unique<Impl>(std::move(world));
  impl->params = p;
  impl->goal = goal;
  // The planners point into impl (map, field): impl never moves, only the Navigator's pointer.
  const map::SurveyNetwork* survey = impl->loaded.survey ? &*impl->loaded.survey : nullptr;
  ADIT_ASSIGN_OR_RETURN(global::GlobalPlanner g, global::GlobalPlanner::create(impl->loaded.map, *impl->field, p.global, survey));
  impl->global.emplace(std::move(g));
  local::World sensed;
  sensed.field = impl->field;
  // A ground robot's footprint is the local planner's own (RobotLimits): it needs no checker.
  sensed.shape = rb.ground() ? map::RobotShape::sphere(rb.radius_m) : p.global.robot;
  ADIT_ASSIGN_OR_RETURN(local::LocalPlanner lp, local::LocalPlanner::create(p.local, sensed));
  impl->local.emplace(std::move(lp));
  impl->path.points = {goal};
  return Navigator(std::move(impl));
}

Status Navigator::plan(const Vec3& start) {
  std::unique_lock lock(impl_->mutex);
  impl_->initial_refinement.reset();
  if (allFinite(start)) impl_->position = start;
  ADIT_ASSIGN_OR_RETURN(global::GlobalPlanResult r, impl_->planFrom(start, impl_->params.refine_plan, false));
  (void)r;
  return {};
}

Status Navigator::setExpectedPath(map::Polyline path) {
  if (path.points.empty() || (path.points.back() - impl_->goal).norm() > 1e-6)
    return invalidArgument("navigator: the expected path must end at the goal");
  for (const Vec3& p : path.points)
    if (!allFinite(p)) return invalidArgument("navigator: the expected path has a non-finite point");
  std::unique_lock lock(impl_->mutex);
  impl_->path = std::move(path);
  impl_->local->reset();
  return {};
}

NavigatorCycle Navigator::cycle(double t_s, const local::RobotState& state, const std::vector<Vec3>& sensed_rock,
                                const std::vector<map::MovingObstacle>& tracks, double dt_s) {
  return run(t_s, state, &sensed_rock, nullptr, tracks, dt_s);
}

NavigatorCycle Navigator::cycleWithScan(double t_s, const local::RobotState& state, const SensorScan& scan,
                                        const std::vector<map::MovingObstacle>& tracks, double dt_s) {
  return run(t_s, state, nullptr, &scan, tracks, dt_s);
}

NavigatorCycle Navigator::run(double t_s, const local::RobotState& state, const std::vector<Vec3>* sensed_rock,
                              const SensorScan* scan, const std::vector<map::MovingObstacle>& tracks, double dt_s) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  NavigatorCycle out;
  if (m.no_route) {
    out.status = NavigatorStatus::kNoRoute;
    out.command.status = local::StepStatus::kRefused;
    out.command.message = "no route to the goal";
    return out;
  }
  if (!allFinite(state.position) || !allFinite(state.velocity) || !std::isfinite(t_s)) {
    out.status = NavigatorStatus::kRefused;
    out.command.status = local::StepStatus::kRefused;
    out.command.message = "non-finite robot state";
    return out;
  }
  m.position = state.position;
  m.last_t_s = t_s;
  out.operator_replanned = m.operator_replanned;
  m.operator_replanned = false;
  // The operator's hand, if any, replaces the attraction in this cycle's local step.
  if (m.paused) m.local->setOverride(Vec3::Zero(), false);
  else if (m.manual) m.local->setOverride(m.manual_velocity, true);
  else m.local->clearOverride();
  std::optional<std::string> replan_reason;
  map::Aabb changed;
  {
    std::unique_lock lock(m.mutex);
    // 1. The map transaction: the scan's rays (returns become rock, what they pass free), or
    // rock points of which only those the map still holds free change anything.
    Status s;
    if (scan) {
      StatusOr<map::MapChange> c = m.loaded.map.insertRays(scan->origin, scan->returns, scan->max_range_m);
      if (c.ok()) out.map_change = *c;
      else s = c.status();
    } else {
      m.fresh.clear();
      for (const Vec3& p : *sensed_rock)
        if (allFinite(p) && m.loaded.map.isFree(p)) m.fresh.push_back(p);
      if (!m.fresh.empty()) s = m.loaded.map.setVoxels(m.fresh, map::VoxelState::kOccupied, &out.map_change);
    }
    out.inserted_points = int(out.map_change.to_occupied);
    if (s.ok() && !out.map_change.empty()) {
      changed = out.map_change.box.inflated(m.field->resolution());
      s = m.field->update(m.loaded.map, changed, &out.field_update);
      if (s.ok()) {
        out.field_updated = true;
        if (out.map_change.to_occupied > 0)
          if (std::optional<Vec3> at = m.blockedAt(state.position, changed))
            replan_reason = "expected path blocked at " + pointText(*at);
      }
    }
    if (!s.ok()) m.events.push_back({t_s, "map_update_failed", s.message(), 0.0, {}, ""});
  }
  // 2. The local step on the (possibly updated) field; stuck asks for a replan too.
  m.chooseSubgoal(t_s, state, tracks);
  out.command = m.local->step(state, m.path, tracks, dt_s);
  if (!replan_reason && out.command.status == local::StepStatus::kStuck &&
      m.stuck_replans < m.params.max_stuck_replans) {
    ++m.stuck_replans;
    replan_reason = "local planner stuck: " + std::string(out.command.message);
  }
  if (replan_reason) {
    std::unique_lock lock(m.mutex);
    const auto r0 = std::chrono::steady_clock::now();
    if (!changed.empty()) m.global->mapChanged(changed);
    StatusOr<global::GlobalPlanResult> r =
        m.planFrom(state.position, m.params.refine_plan && m.params.refine_replans, true);
    out.replan_time_s = secondsSince(r0);
    out.replanned = true;
    ++m.replans;
    if (r.ok()) {
      m.events.push_back({t_s, "replan", *replan_reason, out.replan_time_s, r->route, "", m.last_refine_time_s});
    } else {
      m.no_route = true;
      m.events.push_back({t_s, "no_route", *replan_reason, out.replan_time_s, {}, r.status().message()});
    }
  }
  if (m.no_route) {
    out.status = NavigatorStatus::kNoRoute;
    out.command = local::StepCommand();
    out.command.message = "no route to the goal";
  } else if (out.replanned) {
    // The command of this cycle follows the new path.
    m.chooseSubgoal(t_s, state, tracks);
    out.command = m.local->step(state, m.path, tracks, dt_s);
  }
  if (!m.no_route) {
    switch (out.command.status) {
      case local::StepStatus::kArrived: out.status = NavigatorStatus::kArrived; break;
      case local::StepStatus::kStuck: out.status = NavigatorStatus::kStuck; break;
      case local::StepStatus::kRefused: out.status = NavigatorStatus::kRefused; break;
      default: out.status = NavigatorStatus::kDriving; break;
    }
    if (m.paused) out.status = NavigatorStatus::kPaused;
    else if (m.manual) out.status = NavigatorStatus::kManual;
  }
  out.subgoal = m.subgoal;
  out.cycle_time_s = secondsSince(t0);
  return out;
}

void Navigator::pause() { impl_->paused = true; }
void Navigator::resume() { impl_->paused = false; }
bool Navigator::paused() const { return impl_->paused; }
bool Navigator::manualControl() const { return impl_->manual; }

Vec3 Navigator::goal() const {
  std::shared_lock lock(impl_->mutex);
  return impl_->goal;
}

Status Navigator::setGoal(const Vec3& goal_given) {
  Vec3 goal = goal_given;
  Impl& m = *impl_;
  if (!allFinite(goal)) return invalidArgument("goal: not finite");
  std::unique_lock lock(m.mutex);
  const map::Aabb b = m.loaded.map.bounds();
  if (!b.contains(goal))
    return invalidArgument("goal " + pointText(goal) + " is off the map (bounds " + pointText(b.min) + " to " +
                           pointText(b.max) + ")");
  if (!m.loaded.map.isFree(goal)) return invalidArgument("goal " + pointText(goal) + " is in rock");
  const local::RobotLimits& rb = m.params.local.robot;
  if (rb.ground()) {
    // A ground robot's goal stands on the floor under the point given.
    const std::optional<double> f = map::floorBelow(*m.field, goal, 5.0);
    if (!f) return invalidArgument("goal " + pointText(goal) + ": no floor within 5 m under it for the ground robot");
    goal.z() = *f + 0.5 * rb.height_m;
  }
  const double clearance = m.field->distance(goal + Vec3(0, 0, rb.probeLift(m.field->resolution()))), r = rb.radius_m;
  if (clearance < r) {
    std::ostringstream os;
    os.precision(2);
    os << std::fixed << "goal " << pointText(goal) << " has " << clearance << " m clearance, less than the robot's radius "
       << r << " m";
    return invalidArgument(os.str());
  }
  const Vec3 old_goal = m.goal;
  const bool old_no_route = m.no_route;
  m.goal = goal;
  if (Status s = m.operatorReplan("operator: new goal " + pointText(goal), m.params.refine_plan); !s.ok()) {
    m.goal = old_goal;  // the old goal and its path stay
    m.no_route = old_no_route;
    return s;
  }
  return {};
}

StatusOr<RoadwayBlockResult> Navigator::blockRoadway(const std::string& name) {
  Impl& m = *impl_;
  std::unique_lock lock(m.mutex);
  if (m.blocks.count(name)) return failedPrecondition("roadway '" + name + "' is already blocked");
  ADIT_ASSIGN_OR_RETURN(std::vector<Vec3> voxels, m.blockVoxels(name));
  if (voxels.empty()) return failedPrecondition("roadway '" + name + "': its middle cross-section holds no free voxel");
  const double r = m.params.local.robot.radius_m, res = m.field->resolution();
  for (const Vec3& p : voxels)
    if ((p - m.position).norm() < r + res)
      return failedPrecondition("roadway '" + name + "': the robot stands in its middle cross-section at " +
                                pointText(m.position));
  ADIT_ASSIGN_OR_RETURN(const map::Aabb box, m.writeVoxels(voxels, map::VoxelState::kOccupied, map::VoxelState::kFree));
  RoadwayBlockResult out;
  out.voxels = voxels.size();
  m.blocks.emplace(name, std::move(voxels));
  if (m.blockedAt(m.position, box)) {
    out.replanned = true;
    if (Status s = m.operatorReplan("operator: roadway " + name + " blocked", m.params.refine_plan && m.params.refine_replans);
        !s.ok()) {
      m.no_route = true;
      out.no_route = true;
      out.message = s.message();
    }
  }
  return out;
}

StatusOr<RoadwayBlockResult> Navigator::reopenRoadway(const std::string& name) {
  Impl& m = *impl_;
  std::unique_lock lock(m.mutex);
  if (m.loaded.survey) ADIT_RETURN_IF_ERROR(m.roadway(name).status());
  auto it = m.blocks.find(name);
  if (it == m.blocks.end()) return failedPrecondition("roadway '" + name + "' is not blocked");
  ADIT_RETURN_IF_ERROR(m.writeVoxels(it->second, map::VoxelState::kFree, map::VoxelState::kOccupied).status());
  RoadwayBlockResult out;
  out.voxels = it->second.size();
  m.blocks.erase(it);
  out.replanned = true;
  const bool was_no_route = m.no_route;
  if (Status s = m.operatorReplan("operator: roadway " + name + " reopened", m.params.refine_plan && m.params.refine_replans);
      !s.ok()) {
    m.no_route = was_no_route;  // a robot on its way keeps its path
    out.no_route = true;
    out.message = s.message();
  }
  return out;
}

std::vector<std::string> Navigator::blockedRoadways() const {
  std::shared_lock lock(impl_->mutex);
  std::vector<std::string> out;
  for (const auto& b : impl_->blocks) out.push_back(b.first);
  return out;
}

Status Navigator::manual(const Vec3& velocity) {
  if (!allFinite(velocity)) return invalidArgument("manual: velocity is not finite");
  impl_->manual = true;
  impl_->manual_velocity = velocity;
  return {};
}

Status Navigator::release() {
  Impl& m = *impl_;
  if (!m.manual) return failedPrecondition("release: not in manual control");
  m.manual = false;
  std::unique_lock lock(m.mutex);
  if (Status s = m.operatorReplan("operator: released manual control", m.params.refine_plan && m.params.refine_replans);
      !s.ok()) {
    m.no_route = true;
    return s;
  }
  return {};
}

void Navigator::read(const std::function<void(const map::OccupancyMap&, const map::DistanceField&)>& fn) const {
  std::shared_lock lock(impl_->mutex);
  fn(impl_->loaded.map, *impl_->field);
}

map::Polyline Navigator::expectedPath() const {
  std::shared_lock lock(impl_->mutex);
  return impl_->path;
}

const std::vector<NavigatorEvent>& Navigator::events() const { return impl_->events; }
int Navigator::replans() const { return impl_->replans; }
const std::optional<PlanRefinement>& Navigator::initialRefinement() const { return impl_->initial_refinement; }
const local::SubgoalStats& Navigator::subgoalStats() const { return impl_->subgoal_stats; }
const global::GlobalPlanner& Navigator::globalPlanner() const { return *impl_->global; }

}  // namespace adit::fusion
