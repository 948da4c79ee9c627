// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/navigator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
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
  }
  return "?";
}

struct Navigator::Impl {
  explicit Impl(map::LoadedMap l) : loaded(std::move(l)) {}
  map::LoadedMap loaded;
  std::optional<map::DistanceField> field;
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
  StatusOr<global::GlobalPlanResult> planFrom(const Vec3& from, bool refine) {
    last_refine_time_s = 0.0;
    global::GlobalPlanResult r = global->plan(from, goal);
    if (!r.solved()) {
      return failedPrecondition(std::string("no route from ") + pointText(from) + " to the goal: " + r.message);
    }
    if (refine) {
      PlanRefinement ref = refinePlan(*global, *field, &r);
      last_refine_time_s = ref.time_s;
      if (!initial_refinement) initial_refinement = std::move(ref);
    }
    path = r.path;
    local->reset();
    return r;
  }

  // The first sample of the remaining path (from the robot's nearest segment on) closer to rock
  // than the robot's radius, within `window` grown by the radius.
  std::optional<Vec3> blockedAt(const Vec3& robot, const map::Aabb& window) const {
    const double r = params.local.robot.radius_m;
    const map::Aabb near = window.inflated(r + field->resolution());
    std::size_t first = 0;
    path.nearestPoint(robot, &first);
    const double step = 0.5 * field->resolution();
    for (std::size_t i = first; i + 1 < path.points.size(); ++i) {
      const Vec3 a = path.points[i], b = path.points[i + 1];
      const double len = (b - a).norm();
      const int n = std::max(1, int(std::ceil(len / step)));
      for (int k = 0; k <= n; ++k) {
        const Vec3 p = a + (b - a) * (double(k) / double(n));
        if (near.contains(p) && field->distance(p) < r) return p;
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
  ADIT_ASSIGN_OR_RETURN(map::DistanceField f, map::DistanceField::build(loaded.map));
  return create(std::move(loaded), std::move(f), params, goal);
}

StatusOr<Navigator> Navigator::create(map::LoadedMap loaded, map::DistanceField field, const NavigatorParams& params,
                                      const Vec3& goal) {
  NavigatorParams p = params;
  p.global.robot = map::RobotShape::sphere(p.local.robot.radius_m);
  ADIT_RETURN_IF_ERROR(p.validate());
  if (!allFinite(goal)) return invalidArgument("navigator: goal is not finite");
  if (field.resolution() != loaded.map.resolution())
    return invalidArgument("navigator: the distance field (voxel " + std::to_string(field.resolution()) +
                           " m) was not built from the map (voxel " + std::to_string(loaded.map.resolution()) + " m)");
  auto impl = std::make_unique<Impl>(std::move(loaded));
  impl->params = p;
  impl->goal = goal;
  impl->field.emplace(std::move(field));
  // The planners point into impl (map, field): impl never moves, only the Navigator's pointer.
  const map::SurveyNetwork* survey = impl->loaded.survey ? &*impl->loaded.survey : nullptr;
  ADIT_ASSIGN_OR_RETURN(global::GlobalPlanner g, global::GlobalPlanner::create(impl->loaded.map, *impl->field, p.global, survey));
  impl->global.emplace(std::move(g));
  local::World world;
  world.field = &*impl->field;
  world.shape = p.global.robot;
  ADIT_ASSIGN_OR_RETURN(local::LocalPlanner lp, local::LocalPlanner::create(p.local, world));
  impl->local.emplace(std::move(lp));
  impl->path.points = {goal};
  return Navigator(std::move(impl));
}

Status Navigator::plan(const Vec3& start) {
  std::unique_lock lock(impl_->mutex);
  impl_->initial_refinement.reset();
  ADIT_ASSIGN_OR_RETURN(global::GlobalPlanResult r, impl_->planFrom(start, impl_->params.refine_plan));
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
        m.planFrom(state.position, m.params.refine_plan && m.params.refine_replans);
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
  }
  out.subgoal = m.subgoal;
  out.cycle_time_s = secondsSince(t0);
  return out;
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
