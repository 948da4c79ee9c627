// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// GlobalPlannerParams: everything the global planner is configured with (robot, mode, OMPL
/// planner, budget, seed, safety margin, clearance weight, slope limit), with validate(). The
/// planner copies the params at construction; there are no setters afterwards.
///
///   GlobalPlannerParams p;
///   p.robot = map::RobotShape::capsule(0.4, 1.2);
///   p.mode = PlanMode::kGround;
///   p.planner = PlannerType::kRrtConnect;
///   if (Status s = p.validate(); !s.ok()) return s;

#include <cstdint>
#include <string>

#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::global {

/// kFly: the robot's centre moves freely in R^3 (multi-rotors). kGround: wheeled or tracked
/// robots; the centre stays at the robot's half-height above the roadway floor and slopes
/// steeper than max_slope_deg are refused.
enum class PlanMode { kFly, kGround };
const char* planModeName(PlanMode m);
StatusOr<PlanMode> parsePlanMode(const std::string& name);

/// The OMPL planners adit exposes by name (rrtconnect, rrtstar, informedrrtstar, bitstar, prmstar).
enum class PlannerType { kRrtConnect, kRrtStar, kInformedRrtStar, kBitStar, kPrmStar };
const char* plannerTypeName(PlannerType p);
StatusOr<PlannerType> parsePlannerType(const std::string& name);
/// True for the planners that keep improving until told to stop (all but RRTConnect).
bool isAnytime(PlannerType p);

struct GlobalPlannerParams {
  map::RobotShape robot = map::RobotShape::sphere(0.4);  ///< shape of the robot (see GlobalPlanner)
  PlanMode mode = PlanMode::kFly;
  PlannerType planner = PlannerType::kBitStar;
  double time_budget_s = 2.0;       ///< wall-clock cap on the OMPL search [s], at most kMaxTimeBudgetS
  static constexpr double kMaxTimeBudgetS = 7 * 24 * 3600.0;
  std::uint32_t seed = 1;           ///< all randomness (OMPL and adit's corridor sampler)
  /// Anytime planners stop after this many iterations once they hold an exact solution, so that
  /// the result does not depend on the machine's speed (determinism); the time budget only cuts
  /// in when the machine is too slow, and the result then says so.
  int max_iterations = 1500;
  /// Every planner gives up after this many iterations without an exact solution (0: only the
  /// time budget stops an unsolved search). With it, and a time budget that never cuts in first,
  /// a failed search ends the same way on any machine under any load (batches rely on it).
  long max_unsolved_iterations = 0;
  double safety_margin_m = 0.2;     ///< clearance kept beyond the robot's surface [m]
  /// Clearance-aware cost: a segment costs length * (1 + clearance_weight * p), p = 1 at the
  /// required clearance falling linearly to 0 at preferred_clearance_m more. 0 = pure length.
  double clearance_weight = 0.05;
  double preferred_clearance_m = 1.0;
  /// Motion-check step in voxels (<= 1): every segment is checked at this spacing.
  double motion_step_voxels = 0.5;
  double max_slope_deg = 15.0;      ///< ground mode: steepest floor the robot may climb
  double slope_baseline_m = 3.0;    ///< ground mode: floor slope is measured over this distance
  /// Ground mode: a straight segment between break points may leave the floor+half-height
  /// surface by at most this much (roadways bend in elevation).
  double ground_tolerance_m = 0.3;
  /// Route on the RoadwayGraph and sample only its corridor (true), or plain OMPL over the
  /// map's whole bounding box (false: the baseline adit bench compares against).
  bool use_roadway_graph = true;
  /// Maps without a survey (scans, meshes, .bt/.ot): thickness of the geodesic slices the
  /// free-space roadway graph is cut into [m] (RoadwayGraph::fromFreeSpace).
  double skeleton_cell_m = 1.0;
  /// ... and the memory that graph may take to build; a larger map is refused up front.
  std::uint64_t max_graph_memory_bytes = std::uint64_t(4) << 30;

  Status validate() const;
};

}  // namespace adit::global
