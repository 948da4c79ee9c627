// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Per-period sub-goal selection of Tian 2016 §2.3: each
/// control period t0 the robot aims at a sub-goal in the annulus
/// R ∈ [inner_ratio · v_max · t0, v_max · t0] around it (inner_ratio 3/5 by default; the paper's
/// text also says 2/3).
///  - Farther than ρ0 from every obstacle (static spheres, moving obstacles, rock of the distance
///    field): the point where the segment robot → target crosses the outer circle; no optimisation.
///  - Otherwise the point of the annulus minimising eq. 13,
///      U(z) = U_att(z) + Σ U_rep,static(z) + Σ U_rep,moving(z),
///    with the terms of adit::local (potential_terms.hpp) for the selected LocalParams model at the
///    robot's current velocity and acceleration, found by minimizeGeneticTrustRegion on
///    FeasibleSet::annulus (restricted to points the robot's sphere fits, when a field is given).
///    The straight choice is kept when the optimum is not lower.
/// The models' potentials: classic (Khatib), tian2016 (eq. 9 with the line field along
/// line_a–line_b, eq. 12), wang2014 (Khatib attraction, Ge–Cui repulsion with gain K_2: the fuzzy
/// gain and the field of view depend on the heading, not on z, and are left out), vff/cvff (U_att
/// = K_p |q − q_g|, U = M_p / ρ; CVFF's velocity fields are forces without a potential), uuv
/// (bounded attraction, Ge–Cui repulsion n = 2; the rotation direction has no potential).
///
/// Allocation: the optimiser allocates (Eigen vectors, std::function, its log). This is
/// unavoidable with a general minimiser and acceptable: selection runs once per control period,
/// outside the allocation-free local step().
///
///   SubgoalQuery q{pos, vel, acc, goal, start, goal, &spheres, &moving, &field};
///   SubgoalChoice c = selectSubgoal(q, local_params, SubgoalParams{});
///
/// In a run (`subgoals: ga_trust_region`): sim::simulate() calls subgoalFunction() at the start
/// of every period (the Navigator calls selectSubgoal itself, NavigatorParams::subgoals) and hands
/// the choice to LocalPlanner::setSubgoal(): the attraction pulls toward it, the line field and
/// the progress monitor still follow the expected path's current segment. The request and the
/// answer are adit::local's (subgoal.hpp), so that this layer needs no simulator.
///
///   sim::SimulateOptions opt;
///   opt.subgoals = subgoalFunction(scenario.params, sim::subgoalParamsFor(scenario));
///   StatusOr<sim::SimulationResult> r = sim::simulate(scenario, env, opt);

#include <string>
#include <vector>

#include "adit/fusion/genetic_trust_region.hpp"
#include "adit/local/local_planner.hpp"
#include "adit/local/params.hpp"
#include "adit/local/subgoal.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::fusion {

struct SubgoalParams {
  double t0_s = 1.0;          ///< t0, the control (sampling) period
  double inner_ratio = 0.6;   ///< the annulus' inner radius as a fraction of v_max · t0
  bool planar = true;         ///< a 2-D annulus in x-y at the robot's height; false: a 3-D shell
  GeneticTrustRegionParams optimizer = defaultOptimizer();
  /// The optimiser's defaults with a genetic radius of the annulus' scale.
  static GeneticTrustRegionParams defaultOptimizer();
  Status validate() const;
};

/// The robot and what it knows this period. Pointers are not owned; null means none.
struct SubgoalQuery {
  map::Vec3 position = map::Vec3::Zero();
  map::Vec3 velocity = map::Vec3::Zero();
  map::Vec3 acceleration = map::Vec3::Zero();
  map::Vec3 target = map::Vec3::Zero();  ///< the goal, or the current break point
  map::Vec3 line_a = map::Vec3::Zero();  ///< expected-path segment for Tian's line field
  map::Vec3 line_b = map::Vec3::Zero();
  const std::vector<local::StaticSphere>* static_obstacles = nullptr;
  const std::vector<map::MovingObstacle>* moving = nullptr;  ///< t = 0 is now
  const map::DistanceField* field = nullptr;                 ///< rock (sphere robot of robot.radius_m)
};

enum class SubgoalOutcome {
  kStraight,      ///< far from every obstacle: on the line at the outer radius
  kOptimized,     ///< the annulus' minimum of U (lower than the straight choice)
  kStraightKept,  ///< near obstacles, but the optimiser found nothing lower than the straight choice
  kTargetNear,    ///< the target lies within the outer radius: it is the sub-goal
  kInvalidInput,  ///< bad parameters or non-finite input
};
const char* subgoalOutcomeName(SubgoalOutcome o);

struct SubgoalChoice {
  SubgoalOutcome outcome = SubgoalOutcome::kInvalidInput;
  std::string message;
  map::Vec3 subgoal = map::Vec3::Zero();
  double potential = 0.0;           ///< U at the sub-goal
  double straight_potential = 0.0;  ///< U at the straight choice
  double nearest_obstacle_m = 0.0;  ///< smallest ρ (robot surface to obstacle) at the robot
  double r_inner_m = 0.0, r_outer_m = 0.0;
  OptimizationResult optimization;  ///< empty unless optimised
};

/// U of eq. 13 at `z` for the model `local.method` (exposed so tests and callers compare choices).
double subgoalPotential(const map::Vec3& z, const SubgoalQuery& q, const local::LocalParams& local);

/// Never throws.
SubgoalChoice selectSubgoal(const SubgoalQuery& q, const local::LocalParams& local, const SubgoalParams& params);

/// The selection of one period for a robot at `state` steering along segment line_a → line_b:
/// the query with the break point line_b as target; the pick's `kind` is the outcome's name.
/// kInvalidInput: no point (steer at the break point).
///
/// The pick's `aim` (what sim::simulate() and the Navigator hand to LocalPlanner::setSubgoal)
/// is the sub-goal's bearing from the robot at the break point's distance (at least the
/// sub-goal's own). Interpretation: in the paper the robot moves to the sub-goal within the
/// period, at 3/5 to 1 v_max; the local step's speed instead grows with the force, and an
/// attraction point 0.6-1 m away pulls at a fraction of full speed (Tian's k_q = 0.05: 0.1 N,
/// a fifth of full_speed_force), so the robot would crawl and the progress monitor would call
/// it stuck. The bearing is the paper's choice; far from obstacles the aim is the break point
/// itself (the straight choice lies on the line to it), as without sub-goals.
local::SubgoalPick pickSubgoal(const local::RobotState& state, const map::Vec3& line_a, const map::Vec3& line_b,
                               const std::vector<map::MovingObstacle>* moving,
                               const std::vector<local::StaticSphere>* static_obstacles,
                               const map::DistanceField* field, const local::LocalParams& local,
                               const SubgoalParams& params);

/// The selector as sim::simulate() calls it (sim::SimulateOptions::subgoals).
local::SubgoalFn subgoalFunction(const local::LocalParams& local, const SubgoalParams& params);

}  // namespace adit::fusion
