// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The scenario simulator behind `adit simulate`: drives LocalPlanner::step() period by period
/// with a robot that follows its set-points exactly, moves the obstacles under constant
/// acceleration, and checks collisions itself, independently of the planner: the robot's sphere
/// against rock (CollisionChecker, exact), static spheres and moving obstacles (FCL through
/// map::obstacleDistance, at their true positions), sub-sampled within each period finely enough
/// that nothing can pass through the robot between samples (a quarter of the smallest radius of
/// relative motion per sample). A run that collides is never "arrived". The referee's period
/// (refereePeriod) and its verdicts are shared with the navigated runs (navigated_simulation.hpp),
/// so that both kinds of run are judged alike; the Environment is the true world of either.
///
///   StatusOr<Scenario> sc = loadScenario("maps/scenarios/tian2016_straight.yaml");
///   StatusOr<Environment> env = Environment::load(*sc);        // map + distance field, if any
///   StatusOr<SimulationResult> run = simulate(*sc, *env);
///   std::cout << outcomeName(run->outcome) << " in " << run->arrival_time_s << " s\n";

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>
#include <utility>
#include <string>
#include <vector>

#include "adit/fusion/subgoal_selector.hpp"
#include "adit/local/local_planner.hpp"
#include "adit/local/subgoal.hpp"
#include "adit/map/types.hpp"
#include "adit/sim/scenario.hpp"
#include "adit/status.hpp"

namespace adit::map {
class OccupancyMap;
class World;
}  // namespace adit::map

namespace adit::sim {

/// The static world of a scenario: its map, distance field and collision checker (all absent for
/// open space). Movable; the pointers handed out stay valid.
class Environment {
 public:
  /// Loads the scenario's map (unknown is rock) and builds the field. Open space without `map`.
  static StatusOr<Environment> load(const Scenario& scenario);
  /// Shares an already loaded world (not owned; must outlive the environment): the true world of
  /// a run whose robot starts from the same world's copy (NavigatedOptions::believed).
  static StatusOr<Environment> borrow(const map::World& world);
  /// Shares an already loaded map and field (not owned; must outlive the environment).
  static StatusOr<Environment> borrow(const map::OccupancyMap& map, const map::DistanceField& field);
  static Environment openSpace();

  Environment(Environment&&) noexcept;
  Environment& operator=(Environment&&) noexcept;
  ~Environment();

  const map::OccupancyMap* map() const;
  const map::DistanceField* field() const;
  const map::CollisionChecker* checker() const;

 private:
  struct Impl;
  explicit Environment(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// kNoRoute (the navigator's runs): every roadway to the goal is sealed; the robot stopped.
/// kCollision is the planner's: it drove into rock, an obstacle or a mover it could have braked
/// for. The other two contacts are not: kHitByFall, a roof fall landed where the robot could not
/// stop short of it any more (the navigator's runs); kHitByMover, a mover ran into a robot that
/// was not closing on it (stopped, or backing off: the mover was faster than braking allows).
enum class Outcome { kArrived, kCollision, kStuck, kTimeout, kNoRoute, kHitByFall, kHitByMover };
const char* outcomeName(Outcome o);

/// Why a run that ran out of time or got stuck ended where it did, judged at its end: what a
/// campaign's non-arrivals would need fixed. kRouteOutlastsTime (a timeout only): at the time the
/// robot's last expected path was made, that time plus the path's length at v_max already passed
/// t_max (after a roof fall the only way round can be longer than the time the generator gave
/// for the straight distance): the time budget, not the planner. kShortOfGoal: the robot ended
/// within the terminal phase's range of the goal (TerminalParams::range_m): the field's shape
/// near the goal, the failure the terminal phase is for. kEnRoute: the rest, the route fit in the
/// time and the robot stalled, yielded or wandered on it. kNone for the other outcomes.
enum class EndCause { kNone, kRouteOutlastsTime, kShortOfGoal, kEnRoute };
/// "" for kNone, then "route_outlasts_t_max", "short_of_goal", "en_route".
const char* endCauseName(EndCause c);
/// The inverse of endCauseName(); none for a name it does not write.
std::optional<EndCause> endCauseFromName(std::string_view name);
/// The cause for a run of `sc` that ended with `outcome` at `goal_distance_m` from its goal, its
/// last expected path (of `path_length_m`) made at `path_made_at_s`.
EndCause endCause(const Scenario& sc, Outcome outcome, double goal_distance_m, double path_made_at_s,
                  double path_length_m);

struct TrajectorySample {
  double t_s = 0.0;
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  local::StepStatus status = local::StepStatus::kFollowing;
  /// What the robot steered at during the period that ended here: with sub-goals, the selected
  /// sub-goal (SubgoalPick::point) in force; otherwise StepCommand::sub_goal (the break point, or
  /// an escape's virtual goal). The start for t = 0.
  Vec3 sub_goal = Vec3::Zero();
  double yaw = 0.0;  ///< ground mode: heading [rad]
};

/// Closest approach of the robot's surface to one moving obstacle's.
struct ClosestApproach {
  std::string name;
  double distance_m = std::numeric_limits<double>::infinity();
  double t_s = 0.0;
};

struct SimulationResult {
  Outcome outcome = Outcome::kTimeout;
  std::string message;
  double arrival_time_s = std::numeric_limits<double>::quiet_NaN();  ///< NaN unless arrived
  double arrival_tolerance_m = 0.5;
  double path_length_m = 0.0;
  /// Smallest surface-to-surface distance to rock or any obstacle over the run (sub-sampled).
  double min_clearance_m = std::numeric_limits<double>::infinity();
  int collisions = 0;  ///< periods during which the robot overlapped something
  double first_collision_t_s = std::numeric_limits<double>::quiet_NaN();  ///< NaN without collision
  std::string first_collision_with;  ///< "rock", "static obstacle 2", or the moving obstacle's name
  /// The first contact was with a moving obstacle that the robot was not closing on (its speed
  /// toward the obstacle's centre at most kNotClosingMps): the mover's doing (kHitByMover).
  bool first_collision_by_mover = false;
  int steps = 0;       ///< step() calls
  int escapes = 0;     ///< escape manoeuvres started
  /// When each escape began: the start of the period whose StepCommand::escapes went up (a
  /// replay marks them).
  std::vector<double> escape_times_s;
  double step_time_p50_us = 0.0;
  double step_time_p99_us = 0.0;
  double final_goal_distance_m = 0.0;
  EndCause end_cause = EndCause::kNone;      ///< timeout and stuck: why (see EndCause)
  std::vector<TrajectorySample> trajectory;  ///< one per period, from t = 0
  std::vector<ClosestApproach> closest;      ///< one per moving obstacle
  local::SubgoalStats subgoals;              ///< empty unless the scenario selects sub-goals
  bool arrived() const { return outcome == Outcome::kArrived; }
};

/// The referee's part of one period, shared with the navigator's runs (simulateNavigated): the robot
/// moves from `state` under `acceleration` for sc.dt_s from time t_s; the period is sub-sampled
/// against rock, static and moving obstacles and `extra` (which may lower the distance `d` and
/// name `what`, e.g. a roof fall); `result` gains clearances, closest approaches, collisions and
/// path length (the caller appends the trajectory sample).
using ExtraDistanceFn = std::function<void(const Vec3& p, double t_s, double& d, std::string& what)>;
void refereePeriod(const Scenario& sc, const Environment& env, const Vec3& acceleration, double t_s, local::RobotState& state, SimulationResult& result, const ExtraDistanceFn& extra = {});
/// The same for a whole command: a ground robot also turns at cmd.yaw_rate. In ground mode the
/// robot drives on the floor: each sub-sample's height is half the robot's height above the floor
/// under it (found from the last floor, climbing at most max_step), its pitch and roll follow the
/// floor's plane fitted over a 2.5 m square under it (map::floorSlope: the incline, not the voxel
/// stair under the body), clamped to max_slope_deg, and the body (the footprint's box or cylinder,
/// from max_step plus one voxel above the floor to its height) is checked exactly with FCL.
/// Floor contact is no collision; rock in the body, a step higher than max_step (the body runs
/// into it) or no floor within a metre under the robot ("a drop") is.
void refereePeriod(const Scenario& sc, const Environment& env, const local::StepCommand& cmd, double t_s, local::RobotState& state,
                   SimulationResult& result, const ExtraDistanceFn& extra = {});
/// Ground mode: the scenario with its start, goal and expected path's points put on the floor,
/// half the robot's height above the floor under each (searched down at most 5 m); the error
/// names the point with no floor under it, or in rock. Fly mode, or open space: unchanged.
StatusOr<Scenario> placeOnFloor(const Scenario& sc, const Environment& env);
/// Ground mode: the heading a run starts with, along the expected path's first segment.
double startYaw(const Scenario& sc);
/// The referee's clearance from the robot's body at `p` to rock [m], 0 on contact (ground mode:
/// standing on the floor under p with heading `yaw`); infinity in open space.
double bodyRockClearance(const Scenario& sc, const Environment& env, const Vec3& p, double yaw);
/// How a ground robot's body fits at `p` over 16 headings (it can turn on the spot where every
/// heading fits; it can stand there where one does): the least and the most of the referee's
/// clearance. A flying robot's sphere has one clearance.
struct BodyFit {
  double least_m = 0.0, most_m = 0.0;
};
BodyFit bodyFit(const Scenario& sc, const Environment& env, const Vec3& p);
/// The checks before a run: start and goal free, the robot's body clear of rock at the start
/// (ground: at its start heading) and at the goal (ground: at some heading); the error names the
/// end and the body.
Status checkRunEnds(const Scenario& sc, const Environment& env);
/// "the robot's 1.00 x 0.70 m body" / "the robot (radius 0.40 m)", for messages.
std::string robotBodyName(const local::RobotLimits& robot);
/// Sets outcome kCollision and its message when the run collided; false otherwise.
bool collisionVerdict(SimulationResult& result);
/// The q-quantile (0..1, nearest rank) of per-step times, as the JSON's step_time_us reports it.
double stepTimePercentile(std::vector<double> values, double q);

/// What the caller adds to a run.
struct SimulateOptions {
  /// The sub-goal selector for `subgoals: ga_trust_region` (adit::fusion::subgoalFunction), called
  /// at the start of every subgoal_period_s and when the robot moves on to the next segment.
  local::SubgoalFn subgoals;
};

/// Runs the scenario to arrival, a stuck verdict, or t_max. Errors: a scenario that fails
/// validate(), a start or goal inside rock or overlapping an obstacle, a scenario that
/// needsNavigator() (run those with simulateNavigated(), navigated_simulation.hpp), `subgoals: ga_trust_region`
/// without options.subgoals.
StatusOr<SimulationResult> simulate(const Scenario& scenario, const Environment& environment,
                                    const SimulateOptions& options = {});

/// The sub-goal selector's parameters for a scenario: t0 = `subgoal_period`, the optimiser's
/// seed = `seed`, the rest the defaults (what SimulateOptions::subgoals and the navigated runs
/// select with).
fusion::SubgoalParams subgoalParamsFor(const Scenario& scenario);

}  // namespace adit::sim
