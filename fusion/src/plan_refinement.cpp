// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/plan_refinement.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>

namespace adit::fusion {

PlanRefinement refinePlan(const global::GlobalPlanner& planner, const map::DistanceField& field,
                          global::GlobalPlanResult* r) {
  PlanRefinement out;
  if (r == nullptr || !r->solved()) {
    out.message = "no solved plan to refine";
    return out;
  }
  const global::GlobalPlannerParams& params = planner.params();
  const double res = field.resolution();
  const double horizontal = planner.requiredClearance() - params.safety_margin_m - 0.5 * res;
  BreakPointRefinerParams rp = BreakPointRefinerParams::forField(res, params.safety_margin_m);
  rp.planar = params.mode == global::PlanMode::kGround;
  // Sample as finely as the planner's motion check, which re-validates every refined segment.
  rp.sample_step_m = std::min(res, params.motion_step_voxels * res);
  rp.clearance_weight = params.clearance_weight;
  // The clearance below is the field's distance shifted: the field's error bound holds for it.
  rp.clearance_slack_m = field.errorBound();
  // Ground mode: the centre sits half a body above the floor, so the field there sees the floor;
  // measure the ribs higher up, lifted as the planner's own clearance is (margin + two voxels),
  // and high enough that the floor (two voxels of quantisation under it) never binds: a low wide
  // body (a 1.0 x 0.7 x 0.6 m tracked robot) is wider than it is tall.
  double half_height = 0.0;
  switch (params.robot.type) {
    case map::ShapeType::kSphere: half_height = params.robot.radius; break;
    case map::ShapeType::kCapsule: half_height = params.robot.radius + 0.5 * params.robot.length; break;
    case map::ShapeType::kCylinder: half_height = 0.5 * params.robot.length; break;
    case map::ShapeType::kBox: half_height = 0.5 * params.robot.size.z(); break;
  }
  const double lift = rp.planar ? std::max(params.safety_margin_m + 2.0 * res,
                                           horizontal + params.safety_margin_m + 2.0 * res - half_height)
                                : 0.0;
  // The objective's finite differences sample every segment again with one end moved by 1e-4 m:
  // nearly every sample reads the 8 voxels it read before, kept here.
  map::DistanceReadCache reads;
  const ClearanceFn clearance = [&field, &reads, horizontal, lift](const map::Vec3& p) {
    return field.distance(p + map::Vec3(0, 0, lift), reads) - horizontal;
  };
  const SegmentCheck check = [&planner](const map::Vec3& p, const map::Vec3& q) {
    return planner.validatePath(map::Polyline{{p, q}});
  };
  VertexPlacement place;
  if (rp.planar) {
    // A break point moved sideways stands on the floor there, as the planner's own do (the floor
    // of a sloping roadway is another height a few metres on, and the planner's check allows the
    // centre only a ground tolerance off it).
    place = [&planner](const map::Vec3& p) {
      const std::optional<map::Vec3> q = planner.standAt(p);
      return q ? *q : map::Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    };
    // The measure above is the footprint's circumscribed circle against the ribs, wider than the
    // body the planner's exact check accepted the path with: at a junction's corner a planned
    // path comes nearer than the margin by it. The refined path need only be as clear by this
    // measure as the planned one was; the planner's check re-validates it.
    rp.min_clearance_m = std::min(rp.min_clearance_m, measurePath(r->path, clearance, rp.sample_step_m).min_clearance_m);
  }
  const auto t0 = std::chrono::steady_clock::now();
  BreakPointRefinement ref = refineBreakPoints(r->path, clearance, rp, check, place);
  out.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.outcome = ref.outcome;
  out.message = ref.message;
  out.before_path = r->path;
  out.before = ref.before;
  out.after = ref.after;
  out.objective_before = ref.objective_before;
  out.objective_after = ref.objective_after;
  out.iterations = ref.optimization.iterations;
  r->path = ref.path;
  r->length_m = ref.after.length_m;
  r->min_clearance_m = ref.after.min_clearance_m;
  r->mean_clearance_m = ref.after.mean_clearance_m;
  return out;
}

}  // namespace adit::fusion
