// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The global layer's expected path refined: what `adit plan --refine` and the Navigator (for
/// `expected_path: plan` runs) share. The break points of a GlobalPlanner result move jointly under
/// the genetic trust-region method (refineBreakPoints), with the planner's own motion check (exact
/// robot shape, ground contact, slope) re-validating every segment of the result, so a refined
/// path is exactly as valid as a planned one.
///
/// The clearance measure, before and after alike, is the distance field minus the robot's
/// horizontal radius (planner clearance minus margin and half a voxel), sampled as finely as the
/// planner's motion check; in ground mode it is taken higher up, lifted by margin + two voxels as
/// the planner lifts its own, so the floor under the robot does not count as rock. The planner's
/// clearance_weight also weighs the refiner's clearance penalty (0 = length only).
///
///   global::GlobalPlanResult r = planner.plan(start, goal);
///   if (r.solved()) {
///     PlanRefinement ref = refinePlan(planner, field, &r);   // r.path is now the refined path
///     log(ref.before.length_m, ref.after.length_m, ref.time_s);
///   }

#include <string>

#include "adit/fusion/break_point_refiner.hpp"
#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"

namespace adit::fusion {

struct PlanRefinement {
  RefineOutcome outcome = RefineOutcome::kInvalidInput;
  std::string message;
  map::Polyline before_path;  ///< the path as planned
  PathQuality before, after;  ///< after == before when the input was kept
  /// The refiner's objective, length + w x clearance penalty (w = the planner's clearance_weight):
  /// lower after a refinement, which may buy clearance with a little length.
  double objective_before = 0.0, objective_after = 0.0;
  double time_s = 0.0;        ///< wall time of the refinement, re-validation included
  int iterations = 0;         ///< the optimiser's iterations
};

/// Refines the solved plan `r` in place: r->path, length and clearances become the refined ones
/// (the same figures as the returned `after`), or stay the planner's when the refiner keeps the
/// input. `field` is the one the planner was created on. Never throws; an unsolved `r` is left
/// alone and the outcome is kInvalidInput.
PlanRefinement refinePlan(const global::GlobalPlanner& planner, const map::DistanceField& field,
                          global::GlobalPlanResult* r);

}  // namespace adit::fusion
