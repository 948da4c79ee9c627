// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Break-point refinement (Tian 2016 §2.3 applied to the global layer's expected path): all
/// interior vertices of a polyline move jointly under the genetic trust-region method to make the
/// path shorter while it keeps away from rock.
///
/// Objective (stated, not tuned to any paper's numbers):
///   U(z) = L(z) + w · Σ_segments ∫ φ(c(s)) ds,   φ(c) = ½ (1/c − 1/ρ0)² for c < ρ0, else 0,
/// with L the polyline length, c the clearance function (robot surface to the nearest obstacle),
/// the integral taken by the midpoint rule with samples at most `sample_step_m` apart.
/// Ω (explicit, never a penalty): every vertex within `move_radius_m` of where it started, and
/// every segment clear, c ≥ `min_clearance_m` at samples at most `sample_step_m` apart
/// (forField() adds half a voxel, since a DistanceField query may overstate by that much).
/// Planar mode varies only x and y (ground robots, the papers' 2-D scenarios).
///
/// The input is validated first (a vertex in rock or a blocked segment is refused with the segment
/// named); every segment of the result that differs from the input's is re-validated (plus the
/// caller's own check, e.g. the global planner's motion check). The ends of one that fails go back
/// to where they were and the segments next to them are checked again, so a valid input gives a
/// valid result; it is returned when its objective is lower, otherwise the input comes back
/// unchanged, and the message says which segment failed and why.
///
///   BreakPointRefinerParams p = BreakPointRefinerParams::forField(field.resolution(), 0.2);
///   BreakPointRefinement r = refineBreakPoints(path, fieldClearance(field, 0.4), p);
///   if (r.outcome == RefineOutcome::kRefined) path = r.path;

#include <functional>
#include <string>

#include "adit/fusion/genetic_trust_region.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::fusion {

/// Clearance of the robot at a point: robot surface to the nearest obstacle [m], negative inside.
using ClearanceFn = std::function<double(const map::Vec3&)>;
/// The map's clearance for a robot whose horizontal extent is `robot_radius_m`: field distance
/// minus the radius. The field must outlive the function.
ClearanceFn fieldClearance(const map::DistanceField& field, double robot_radius_m);

struct BreakPointRefinerParams {
  double clearance_weight = 1.0;  ///< w: weight of the penalty's line integral against length
  double rho0_m = 2.0;            ///< ρ0: clearance beyond which rock no longer costs anything
  double min_clearance_m = 0.2;   ///< Ω: clearance required at every sample
  double sample_step_m = 0.2;     ///< longest distance between samples (the voxel size)
  double move_radius_m = 3.0;     ///< Ω: how far a vertex may move from its start
  bool planar = false;            ///< only x and y vary
  /// When >= 0: the clearance function obeys c(q) >= c(p) - |p - q| - slack (a distance
  /// field's does, with DistanceField::errorBound()), and the feasibility scans skip the samples
  /// that this proves clear (the same answers, fewer reads). Negative: every sample is read.
  double clearance_slack_m = -1.0;
  /// Fewer iterations and a smaller, shorter genetic search than the optimiser's defaults: the
  /// dimension is 2–3 per break point and every evaluation walks the whole path.
  GeneticTrustRegionParams optimizer = defaultOptimizer();

  static GeneticTrustRegionParams defaultOptimizer();
  /// For a DistanceField of `resolution_m`: samples a voxel apart, required clearance
  /// margin + half a voxel (the field's query error).
  static BreakPointRefinerParams forField(double resolution_m, double safety_margin_m);
  Status validate() const;
};

enum class RefineOutcome {
  kRefined,       ///< a valid path with a lower objective
  kKeptInput,     ///< nothing to refine, nothing better found, or the result failed re-validation
  kInvalidInput,  ///< bad parameters, NaN, fewer than two points, or a segment not clear
};
const char* refineOutcomeName(RefineOutcome o);

/// Length, clearance sampled along the path (one sample per step, end points included), break points.
struct PathQuality {
  double length_m = 0.0;
  double min_clearance_m = 0.0;
  double mean_clearance_m = 0.0;
  std::size_t break_points = 0;
};
PathQuality measurePath(const map::Polyline& path, const ClearanceFn& clearance, double sample_step_m);

struct BreakPointRefinement {
  RefineOutcome outcome = RefineOutcome::kInvalidInput;
  std::string message;
  map::Polyline path;  ///< the refined path, or the input when not refined
  PathQuality before, after;
  double objective_before = 0.0, objective_after = 0.0;
  OptimizationResult optimization;  ///< the optimiser's result and iteration log
};

/// Extra validity of one segment the caller insists on (e.g. GlobalPlanner::validatePath): run on
/// every segment of the result only (it may be slow). Empty = none.
using SegmentCheck = std::function<Status(const map::Vec3&, const map::Vec3&)>;

/// Planar mode: where a vertex moved to (x, y) stands, i.e. its height there (a ground robot on
/// its floor: the floor rises and falls under a vertex that moves); a non-finite point where it
/// cannot stand. Empty = the vertex keeps its height.
using VertexPlacement = std::function<map::Vec3(const map::Vec3&)>;

/// Never throws. The input's first and last points never move.
BreakPointRefinement refineBreakPoints(const map::Polyline& path, const ClearanceFn& clearance,
                                       const BreakPointRefinerParams& params, const SegmentCheck& extra_check = {},
                                       const VertexPlacement& place = {});

}  // namespace adit::fusion
