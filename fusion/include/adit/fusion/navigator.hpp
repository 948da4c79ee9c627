// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Navigator: the library a robot links. It holds the robot's believed map, its distance field,
/// the roadway graph (inside the GlobalPlanner), the expected path and the LocalPlanner. Every
/// control period cycle() takes the robot state, the rock points its sensor returns and the
/// moving-obstacle tracks, and returns the command:
///
///   1. map transaction: sensed rock points that the map still holds free are written with
///      OccupancyMap::setVoxels and the field is made exact again with DistanceField::update over
///      the changed box; the cycle report says what the update recomputed and whether it fell back
///      to a full rebuild;
///   2. if the remaining expected path now passes closer to rock than the robot's radius (a roof
///      fall on it), or the local layer said kStuck, the roadway graph re-checks its edges in the
///      changed window (RoadwayGraph::refreshBlocked through GlobalPlanner::mapChanged) and the
///      global layer replans from where the robot is; the event (time, reason, route, replan time)
///      is recorded. No route: the command is zero and the status kNoRoute, for good;
///   3. the local step (LocalPlanner::step) along the expected path; with NavigatorParams::subgoals,
///      toward the sub-goal selected (selectSubgoal, Tian 2016 §2.3) at the start of each period
///      t0, when the robot moved on to the next segment, and after the expected path changed.
///      The selection allocates (the optimiser) and takes the optimiser's time in those cycles.
///
/// Time per cycle is bounded by the sensed points (each inserted once) and the local step, except
/// in a cycle that replans; the report gives both times.
///
/// One writer, concurrent readers: the navigator is the single writer of map, field and graph, and
/// writes only inside cycle() (and plan()), under an exclusive lock. Any other thread (a viewer, a
/// logger, a planner of one's own) reads only through read(), which holds the shared lock for the
/// duration of its callback: it sees the world before or after a transaction, never half of one.
/// The navigator replans on the cycle's own thread, inside the exclusive lock, so a replan needs
/// no snapshot. The navigator is not copyable; calls to cycle() must come from one thread.
///
///   StatusOr<Navigator> nav = Navigator::create(std::move(loaded), params, goal);
///   ADIT_RETURN_IF_ERROR(nav->plan(start));
///   for (;;) {
///     NavigatorCycle c = nav->cycle(t, state, lidar_rock_points, tracks, 0.1);
///     if (c.status == NavigatorStatus::kNoRoute) break;   // command is zero: stay put
///     send(c.command.velocity, c.command.acceleration);
///   }

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/fusion/plan_refinement.hpp"
#include "adit/fusion/subgoal_selector.hpp"
#include "adit/global/global_planner.hpp"
#include "adit/local/local_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/world.hpp"
#include "adit/status.hpp"

namespace adit::fusion {

using map::Vec3;

struct NavigatorParams {
  global::GlobalPlannerParams global;  ///< robot shape taken from `local.robot.radius_m`
  local::LocalParams local = local::LocalParams::preset(local::Method::kTian2016);
  /// Replans allowed for kStuck verdicts (a blocked path always replans); beyond, the navigator
  /// reports kStuck instead of replanning forever.
  int max_stuck_replans = 3;
  /// A replan starts where the robot is. Inside the global planner's safety margin (it swerved,
  /// or rock was sensed beside it) that start is refused; the replan then starts from the nearest
  /// valid pose up the distance field, at most this far [m], the path beginning with the robot's
  /// own position. 0: refuse (the run ends no_route).
  double replan_back_off_m = 1.0;
  /// plan() refines the expected path's break points (refinePlan, plan_refinement.hpp: genetic
  /// trust region, every segment re-validated by the global planner's motion check). It runs
  /// inside plan()'s exclusive lock: readers wait for it (0.1-1.8 s on the district's paths).
  bool refine_plan = false;
  /// Replans are refined too (with refine_plan). Off by default: a replan happens mid-run, in
  /// the cycle that found the path blocked, and the refinement's time adds to that cycle's.
  bool refine_replans = false;
  /// Per-period sub-goals (`subgoals: ga_trust_region`) instead of steering at the break points;
  /// `subgoal.t0_s` is the period.
  bool subgoals = false;
  SubgoalParams subgoal;
  Status validate() const;
};

/// kPaused and kManual: the operator holds the robot or drives it (pause(), manual()); the run
/// goes on.
enum class NavigatorStatus { kDriving, kArrived, kStuck, kNoRoute, kRefused, kPaused, kManual };
const char* navigatorStatusName(NavigatorStatus s);

/// Something the navigator decided: a replan (and why) or the end of the road.
struct NavigatorEvent {
  double t_s = 0.0;
  std::string type;     ///< "replan" | "no_route" | "map_update_failed"
  std::string reason;   ///< "expected path blocked at (x, y, z)", "local planner stuck", ...
  double replan_time_s = 0.0;      ///< planning plus refinement
  std::vector<std::string> route;  ///< roadways of the new route (replan)
  std::string message;  ///< the global layer's message (no_route)
  double refine_time_s = 0.0;  ///< of replan_time_s, the refinement's (refine_replans)
};

/// One range scan (a lidar sweep) for ray insertion: the returns the sensor saw from `origin`;
/// returns beyond `max_range_m` count as rays without a return (they only clear).
struct SensorScan {
  Vec3 origin = Vec3::Zero();
  std::vector<Vec3> returns;
  double max_range_m = 10.0;
};

struct NavigatorCycle {
  local::StepCommand command;     ///< zero set-points unless kDriving
  NavigatorStatus status = NavigatorStatus::kDriving;
  int inserted_points = 0;        ///< sensed rock voxels new to the map this cycle
  map::MapChange map_change;      ///< what the cycle's map transaction changed (box, counts)
  bool field_updated = false;
  map::DistanceFieldUpdateReport field_update;
  bool replanned = false;
  double replan_time_s = 0.0;
  double cycle_time_s = 0.0;      ///< whole cycle, replan included
  std::optional<Vec3> subgoal;    ///< the per-period sub-goal in force (NavigatorParams::subgoals)
  /// An operator command replanned since the previous cycle (setGoal, a block, reopen, release).
  bool operator_replanned = false;
};

/// The robot's status as the operations console names it (its telemetry's `status`): following,
/// yielding, detouring (the local step while driving), replanning (this cycle, or an operator
/// command since the last, replanned), stuck, no_route, paused, manual, arrived. `collision` is
/// the referee's word, not the navigator's. A refused cycle (non-finite input) reads "stuck".
const char* consoleStatusName(const NavigatorCycle& c);

/// What blockRoadway() / reopenRoadway() did.
struct RoadwayBlockResult {
  std::size_t voxels = 0;   ///< free voxels of the cross-section made rock (block) or free again (reopen)
  bool replanned = false;   ///< the expected path crossed the block (block) / always (reopen)
  bool no_route = false;    ///< the replan found no route: the navigator stops (kNoRoute) until a reopen or new goal
  std::string message;      ///< the global layer's message when no route
};

class Navigator {
 public:
  /// Takes over the believed world (map, survey, field: with a survey the roadway graph is exact)
  /// and builds the planners on it. The goal is fixed for the navigator's life.
  static StatusOr<Navigator> create(map::World world, const NavigatorParams& params, const Vec3& goal);
  /// The same for a map alone: builds its field first.
  static StatusOr<Navigator> create(map::LoadedMap loaded, const NavigatorParams& params, const Vec3& goal);
  /// The same with the field already built from `loaded.map` (e.g. copied from a preloaded one:
  /// the distance transform is a large part of a short simulated run). The field must be
  /// DistanceField::build(loaded.map) with its defaults; a resolution that differs is refused.
  static StatusOr<Navigator> create(map::LoadedMap loaded, map::DistanceField field, const NavigatorParams& params,
                                    const Vec3& goal);
  Navigator(Navigator&&) noexcept;
  Navigator& operator=(Navigator&&) noexcept;
  ~Navigator();

  /// Plans the expected path from `start` with the global layer, refined when
  /// NavigatorParams::refine_plan says so (see initialRefinement()). Error: failedPrecondition
  /// with the planner's message when there is no route.
  Status plan(const Vec3& start);
  /// Uses `path` (ending at the goal) instead of planning.
  Status setExpectedPath(map::Polyline path);

  /// One control period at time t_s (see the file comment). Never throws; non-finite input gives
  /// kRefused with a zero command.
  NavigatorCycle cycle(double t_s, const local::RobotState& state, const std::vector<Vec3>& sensed_rock,
                       const std::vector<map::MovingObstacle>& tracks, double dt_s);
  /// The same with a range scan, inserted as rays (OccupancyMap::insertRays): what the rays pass
  /// becomes free again, so rubble that has been cleared away stops blocking the map. A cleared
  /// roadway is not replanned into by itself; the next replan may use it.
  NavigatorCycle cycleWithScan(double t_s, const local::RobotState& state, const SensorScan& scan,
                       const std::vector<map::MovingObstacle>& tracks, double dt_s);

  // Operator commands (the operations console's, adit::console). Call them between cycles, from the
  // cycle's thread; the ones that replan do it at once from the position of the last cycle (or
  // plan()'s start) and take the exclusive lock.

  /// Holds position from the next cycle on: velocity set-point zero, the local layer still gives
  /// way to moving obstacles (LocalPlanner::setOverride without the rock terms). Status kPaused.
  void pause();
  /// Ends a pause (a manual drive continues if one was in force before).
  void resume();
  bool paused() const;
  /// A new goal: refused (invalidArgument, with the reason) when non-finite, off the map, in rock
  /// (unknown counts as rock) or with clearance below the robot's radius; refused
  /// (failedPrecondition, the planner's message) when no route reaches it, and then the old goal
  /// and path stay. Otherwise replans from the robot's position (refined as NavigatorParams
  /// say) and clears a no-route verdict.
  Status setGoal(const Vec3& goal);
  Vec3 goal() const;
  /// Closes the survey roadway `name` across its middle cross-section: a slab two voxels thick
  /// over the whole section (grown by a voxel) whose free voxels become rock in the believed map
  /// (OccupancyMap::setVoxels + DistanceField::update); replans when the expected path crosses
  /// it. Errors: no survey, an unknown name (the message lists the known ones), a roadway
  /// already blocked, a map update that fails (nothing changed then).
  StatusOr<RoadwayBlockResult> blockRoadway(const std::string& name);
  /// Undoes blockRoadway(name): exactly the voxels it made rock become free again; replans.
  StatusOr<RoadwayBlockResult> reopenRoadway(const std::string& name);
  /// The roadways blocked now, by name.
  std::vector<std::string> blockedRoadways() const;
  /// Drives with the operator's velocity set-point instead of the attraction (a new call
  /// replaces it); the local layer still applies the rock's and the moving obstacles' repulsion,
  /// its braking cap and speed caps (LocalPlanner::setOverride). Status kManual. Refuses a
  /// non-finite velocity.
  Status manual(const Vec3& velocity);
  /// Ends manual control: replans from where the robot is and follows the new expected path.
  /// Error when not in manual control, or (failedPrecondition) no route from here.
  Status release();
  bool manualControl() const;

  /// Runs `fn` on the believed map and field under the shared lock (the readers' side of the
  /// one-writer rule).
  void read(const std::function<void(const map::OccupancyMap&, const map::DistanceField&)>& fn) const;

  map::Polyline expectedPath() const;  ///< a copy, under the shared lock
  /// The navigator's decisions so far; like replans(), for the cycle's own thread only.
  const std::vector<NavigatorEvent>& events() const;
  int replans() const;  ///< replans attempted, the one that found no route included
  /// How plan() refined the expected path: before/after length and clearance, time; empty
  /// without refine_plan or before plan().
  const std::optional<PlanRefinement>& initialRefinement() const;
  /// The sub-goal selections so far (NavigatorParams::subgoals); for the cycle's own thread only.
  const local::SubgoalStats& subgoalStats() const;
  const global::GlobalPlanner& globalPlanner() const;

 private:
  struct Impl;
  explicit Navigator(std::unique_ptr<Impl> impl);
  NavigatorCycle run(double t_s, const local::RobotState& state, const std::vector<Vec3>* sensed_rock,
                     const SensorScan* scan, const std::vector<map::MovingObstacle>& tracks, double dt_s);
  std::unique_ptr<Impl> impl_;
};

}  // namespace adit::fusion
