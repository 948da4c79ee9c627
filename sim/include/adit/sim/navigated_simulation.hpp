// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The scenario simulator for runs that need the Navigator: `expected_path: plan`,
/// `robot.sensor_range` and `events` (roof falls). It keeps two worlds apart:
///
/// - the TRUE world: the scenario's map as loaded into the Environment, plus every roof
///   fall that has happened (a ball of rock). The referee measures the robot's sphere against it:
///   against the map exactly (CollisionChecker, FCL), against a fall ball in closed form, against
///   moving obstacles with map::obstacleDistance, sub-sampled within each period as
///   simulate() does;
/// - the BELIEVED world: the Navigator's own map::World (loaded separately, or the copy() of
///   NavigatedOptions::believed, so it shares no octree with the true one). It learns a fall only
///   through the sensor: every period the
///   fall's surface voxels (free roadway in the true map, touching open roadway) within
///   `robot.sensor_range` that the robot's centre can see (OccupancyMap::lineOfSight through the
///   true map and every fall, voxel by voxel along the ray insertRays() traces; it sees through
///   dust) go to Navigator::cycleWithScan() as one scan, inserted as rays.
///
/// A run ends in arrival, collision, no_route (the navigator found every roadway sealed and
/// stopped), stuck, or t_max.
///
///   StatusOr<Scenario> sc = loadScenario("maps/scenarios/district_rescue.yaml");
///   StatusOr<map::World> world = map::World::load(*sc->map_path);   // loaded once
///   StatusOr<Environment> truth = Environment::borrow(*world);
///   NavigatedOptions options;
///   options.believed = &*world;                                  // the robot starts from its copy
///   StatusOr<NavigatedRun> run = simulateNavigated(*sc, *truth, options);
///   std::cout << run->replans << " replans, " << outcomeName(run->run.outcome) << "\n";

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "adit/fusion/navigator.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/sim/scenario.hpp"
#include "adit/sim/simulator.hpp"
#include "adit/status.hpp"

namespace adit::sim {

/// Sensor range when the scenario gives none [m].
inline constexpr double kDefaultSensorRangeM = 10.0;

struct NavigatedRun {
  /// Outcome (kNoRoute included), trajectory, clearances; step_time_* are the navigator's cycle
  /// times in cycles that did not replan.
  SimulationResult run;
  int replans = 0;
  std::vector<fusion::NavigatorEvent> events;  ///< the navigator's decisions
  map::Polyline initial_path;          ///< the expected path at t = 0
  map::Polyline final_path;            ///< the expected path at the end
  double max_replan_time_s = 0.0;
  /// Longest cycle that did not replan (a map transaction with a field update included) [s].
  double max_cycle_time_s = 0.0;
  /// Smallest distance from the robot's surface to any roof-fall ball over the run (inf without).
  double min_fall_clearance_m = std::numeric_limits<double>::infinity();
  /// `expected_path: plan` with refinement: the initial path before (initial_path is after) and
  /// after the break-point refinement, with its time.
  std::optional<fusion::PlanRefinement> refinement;
  /// Each expected path the run changed to after the start (a replan's, an operator's), with the
  /// time of the cycle that made it: a replay draws each from its time on (initial_path before).
  struct PathChange {
    double t_s = 0.0;
    map::Polyline path;
  };
  std::vector<PathChange> path_changes;
  /// The roof-fall rock the sensor returned, each voxel centre once, at the time of the period it
  /// was first seen (what the believed map learnt, and when).
  struct SensedRock {
    double t_s = 0.0;
    Vec3 point = Vec3::Zero();
  };
  std::vector<SensedRock> sensed;
  double end_time_s = 0.0;             ///< simulated time when the run ended
  double wall_time_s = 0.0;            ///< the whole simulation, map loading included
  /// Of wall_time_s: the believed world (a copy of NavigatedOptions::believed, or loaded) and the
  /// navigator made from it; the initial plan with its refinement. The rest is the run itself.
  double setup_time_s = 0.0;
  double initial_plan_time_s = 0.0;
};

/// Watches, and may steer, a navigated run while it goes: the live link to the operations console
/// (`adit simulate --live`) is one. Every hook runs on the simulation's thread, between
/// control periods. With an observer the run goes on through kPaused and kManual (the operator
/// holds or drives the robot); it still ends in arrival (at the navigator's goal, which the
/// operator may have changed), no_route, stuck, collision or t_max.
class NavigatedObserver {
 public:
  virtual ~NavigatedObserver() = default;
  /// The expected path the run starts with (after plan() or the scenario's path).
  virtual void started(const fusion::Navigator& nav, const map::Polyline& path) = 0;
  /// Before the cycle at `t_s`: the place to give the navigator operator commands.
  virtual void beforeCycle(double t_s, fusion::Navigator& nav, const local::RobotState& state) = 0;
  /// A roof fall happened in the true world at its `t_s`.
  virtual void roofFall(const ScenarioEvent& event) = 0;
  /// After the cycle at `t_s` and the robot's move: `state` is at `t_s + dt`. `scan` is what the
  /// sensor returned this period, `tracks` the moving obstacles it tracked; `result` the referee's
  /// account so far (collisions).
  virtual void afterCycle(double t_s, const fusion::Navigator& nav, const fusion::NavigatorCycle& cycle, const local::RobotState& state,
                          const fusion::SensorScan& scan, const std::vector<map::MovingObstacle>& tracks,
                          const SimulationResult& result) = 0;
  /// The run is over: the verdict is in `result` (outcome), the robot at `state`.
  virtual void finished(double t_s, const fusion::Navigator& nav, const local::RobotState& state,
                        const SimulationResult& result) = 0;
};

/// How the navigator treats a planned expected path (`expected_path: plan`; a given one is never
/// refined).
struct NavigatedOptions {
  bool refine_plan = true;       ///< NavigatorParams::refine_plan
  bool refine_replans = false;   ///< NavigatorParams::refine_replans
  /// The robot's belief at t = 0, loaded once for many runs on one map (a batch, a campaign, or
  /// the true world of the same run): when its path() is the scenario's map, each run starts from
  /// its copy() instead of loading the map again, so runs share nothing they mutate. On the
  /// district, voxelizing the survey and the distance transform are most of a short run's CPU
  /// time. Not owned.
  const map::World* believed = nullptr;
  /// Watches and steers the run (not owned); null: none.
  NavigatedObserver* observer = nullptr;
};

/// Runs the scenario (its map is required: the navigator plans on it). Errors: those of
/// simulate() for bad input, a scenario without a map, static_obstacles (not supported by
/// the navigator).
StatusOr<NavigatedRun> simulateNavigated(const Scenario& scenario, const Environment& truth,
                                         const NavigatedOptions& options = {});

}  // namespace adit::sim
