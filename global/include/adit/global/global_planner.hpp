// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// GlobalPlanner: the *expected path* from a start to a goal through the mine, a polyline with
/// few break points (A, B, ...) that the local planner follows. Pipeline:
///   1. check start and goal (finite, inside the map, not in rock or unknown space, robot fits);
///   2. route on the RoadwayGraph (A* over the roadways; blocked ones are skipped, and start and
///      goal in disconnected parts give "no path" at once, without sampling);
///   3. OMPL plans inside the route's corridor only (adit's own state sampler draws from the
///      corridor's free space; validity and motions from RobotValidity at the voxel-size step);
///   4. OMPL's PathSimplifier, then adit's deterministic shortcutting and break-point relaxation,
///      every segment re-validated after each step.
/// OMPL stays behind the pimpl. Determinism: OMPL's RNG is seeded from params.seed before any
/// planner exists, adit's sampler is seeded likewise, everything runs on one thread, and anytime
/// planners stop on an iteration count (GlobalPlannerParams::max_iterations) rather than on the
/// clock: same inputs and seed give the same path, byte for byte, unless the time budget cuts in
/// first (then GlobalPlanResult::time_limited says so). PRM* grows its roadmap on a second thread
/// inside OMPL and is therefore not deterministic. Because OMPL's seed is process-global, plan()
/// must not run on two threads at once (even on different planners).
///
///   StatusOr<GlobalPlanner> planner = GlobalPlanner::create(map, field, params, survey_or_null);
///   GlobalPlanResult r = planner->plan({0, 0, 1.5}, {600, 15, -21});
///   if (r.solved()) follow(r.path); else std::cerr << r.message;

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/global/global_planner_params.hpp"
#include "adit/global/roadway_graph.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::global {

enum class GlobalPlanOutcome {
  kExactSolution,        ///< a valid path from start to goal
  kApproximateSolution,  ///< OMPL got only near the goal within the budget (path not to the goal)
  kStartInRock,          ///< start in rock, or the robot does not fit there
  kGoalInRock,
  kStartUnknown,         ///< start in unknown space (rock under the map's policy)
  kGoalUnknown,
  kStartOutsideMap,
  kGoalOutsideMap,
  kTimeout,              ///< no path within the time budget
  kNoPath,               ///< start and goal are disconnected (roadways blocked or absent)
  kError,                ///< OMPL failed unexpectedly (the message says how)
};
/// "exact", "approximate", "start_in_rock", ..., "timeout", "no_path", "error" (the JSON's outcome).
const char* outcomeName(GlobalPlanOutcome o);
/// Outcomes caused by the start or goal themselves (the CLI's "bad input").
bool isInvalidEndpoint(GlobalPlanOutcome o);

struct GlobalPlanResult {
  GlobalPlanOutcome outcome = GlobalPlanOutcome::kNoPath;
  std::string message;               ///< human-readable, filled for every outcome
  map::Polyline path;                ///< break points, start first and goal last; empty unless found
  double length_m = 0.0;
  double min_clearance_m = 0.0;      ///< robot surface to rock, sampled along the path
  double mean_clearance_m = 0.0;
  double planning_time_s = 0.0;      ///< whole plan() call
  double first_solution_time_s = 0.0;  ///< from the call until OMPL's first exact (raw) path
  double ompl_time_s = 0.0;          ///< OMPL search alone
  std::string planner;
  std::vector<std::string> route;    ///< roadways of the route, in order
  std::vector<int> route_edges;      ///< RoadwayGraph edge ids of the route
  bool time_limited = false;         ///< the time budget stopped the search (results may vary)
  /// The search found no path within the budget and the path is the route's own axis, shortened
  /// (valid and re-checked like any other, but not searched for the shortest).
  bool from_route_axis = false;
  /// Ground mode, box robots: the robot's turning circle does not fit everywhere along the path,
  /// which was planned with the box at the heading of each segment and the turns at its break
  /// points checked (the robot must not turn on the spot elsewhere).
  bool headed = false;
  long iterations = 0;               ///< OMPL iterations (termination-condition checks) of the search
  std::size_t ompl_vertices = 0;     ///< vertices of OMPL's raw path

  bool solved() const { return outcome == GlobalPlanOutcome::kExactSolution; }
};

class GlobalPlanner {
 public:
  /// `map` and `field` must outlive the planner. With a survey the roadway graph is exact;
  /// without one it is built from the free space (slower to create, see RoadwayGraph).
  static StatusOr<GlobalPlanner> create(const map::OccupancyMap& map, const map::DistanceField& field,
                                        const GlobalPlannerParams& params,
                                        const map::SurveyNetwork* survey = nullptr);
  GlobalPlanner(GlobalPlanner&&) noexcept;
  GlobalPlanner& operator=(GlobalPlanner&&) noexcept;
  ~GlobalPlanner();

  GlobalPlanResult plan(const map::Vec3& start, const map::Vec3& goal) const;

  /// After OccupancyMap::setVoxels + DistanceField::update over `changed` (a roof fall): the
  /// roadway edges there are re-checked. Returns the number of blocked edges.
  int mapChanged(const map::Aabb& changed);

  /// OK when every segment of `path` is a valid motion for this robot at the motion-check step
  /// (the same check plan() applies after every simplification); the error names the segment.
  Status validatePath(const map::Polyline& path) const;

  /// The robot may stand at `c` (ground mode: c is its centre above the floor); the grid
  /// optimum and the tests ask this.
  bool stateValid(const map::Vec3& c) const;

  /// Ground mode: where the robot stands over (c.x, c.y), its centre half its height above the
  /// floor found searching down from half a metre above c (as the planner puts its own break
  /// points); nullopt where there is no floor within reach or c is not finite. Flying: c.
  std::optional<map::Vec3> standAt(const map::Vec3& c) const;

  /// A robot pressed inside the safety margin (after an evasive manoeuvre, or a fall beside it)
  /// is not in rock, but plan() refuses it as a start. This is the nearest pose it may stand at,
  /// reached from `c` by climbing the distance field in half-voxel steps (ground mode: kept on
  /// the floor), at most `max_move_m` away; nullopt when `c` is in rock or no such pose is that
  /// close. `c` itself when it is already valid.
  std::optional<map::Vec3> backOff(const map::Vec3& c, double max_move_m) const;

  const RoadwayGraph& graph() const;
  RoadwayGraph& graph();
  const GlobalPlannerParams& params() const;
  /// Field distance the robot's centre needs (radius + margin + half a voxel).
  double requiredClearance() const;

 private:
  struct Impl;
  explicit GlobalPlanner(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace adit::global
