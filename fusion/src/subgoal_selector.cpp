// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/subgoal_selector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "adit/local/potential_terms.hpp"

namespace adit::fusion {

using local::Method;
using local::Proximity;
using local::TermValue;
using map::Vec3;

GeneticTrustRegionParams SubgoalParams::defaultOptimizer() {
  GeneticTrustRegionParams p;
  p.delta0 = 0.2;
  p.ga_radius = 1.0;
  p.max_iterations = 200;
  p.max_restarts = 5;
  p.ga_population = 30;
  p.ga_generations = 20;
  return p;
}

Status SubgoalParams::validate() const {
  auto bad = [](const char* field, double v, const char* rule) {
    std::ostringstream os;
    os << "sub-goal selector: " << field << " = " << v << " must be " << rule;
    return invalidArgument(os.str());
  };
  if (!(t0_s > 0) || !std::isfinite(t0_s)) return bad("t0_s", t0_s, "> 0");
  if (!(inner_ratio > 0 && inner_ratio < 1)) return bad("inner_ratio", inner_ratio, "in (0, 1)");
  return optimizer.validate();
}

const char* subgoalOutcomeName(SubgoalOutcome o) {
  switch (o) {
    case SubgoalOutcome::kStraight: return "straight";
    case SubgoalOutcome::kOptimized: return "optimized";
    case SubgoalOutcome::kStraightKept: return "straight_kept";
    case SubgoalOutcome::kTargetNear: return "target_near";
    case SubgoalOutcome::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

namespace {

// ρ0 of the selected model: beyond it no obstacle term acts.
double influenceDistance(const local::LocalParams& P) {
  switch (P.method) {
    case Method::kClassic: return P.classic.rho0_m;
    case Method::kTian2016: return P.tian2016.rho0_m;
    case Method::kWang2014: return P.wang2014.sensing_radius_m;
    case Method::kVff:
    case Method::kCvff: return P.vff.p0_m;
    case Method::kUuv: return P.uuv.rho0_m;
  }
  return 0.0;
}

// Calls `f(proximity, v_rel, a_rel)` for every obstacle as seen from z.
template <class F>
void forEachObstacle(const Vec3& z, const SubgoalQuery& q, double rr, F&& f) {
  if (q.static_obstacles)
    for (const local::StaticSphere& s : *q.static_obstacles)
      f(local::sphereProximity(z, s.center, s.radius, rr), q.velocity, q.acceleration);
  if (q.moving)
    for (const map::MovingObstacle& m : *q.moving)
      f(local::sphereProximity(z, m.position, m.shape.boundingRadius(), rr), Vec3(q.velocity - m.velocity),
        Vec3(q.acceleration - m.acceleration));
  if (q.field) {
    const map::DistanceSample s = q.field->query(z);
    f(local::pointProximity(z, s.nearest, rr), q.velocity, q.acceleration);
  }
}

bool finiteQuery(const SubgoalQuery& q) {
  if (!map::allFinite(q.position) || !map::allFinite(q.velocity) || !map::allFinite(q.acceleration) ||
      !map::allFinite(q.target) || !map::allFinite(q.line_a) || !map::allFinite(q.line_b))
    return false;
  if (q.static_obstacles)
    for (const local::StaticSphere& s : *q.static_obstacles)
      if (!map::allFinite(s.center) || !std::isfinite(s.radius)) return false;
  if (q.moving)
    for (const map::MovingObstacle& m : *q.moving)
      if (!map::allFinite(m.position) || !map::allFinite(m.velocity) || !map::allFinite(m.acceleration)) return false;
  return true;
}

}  // namespace

double subgoalPotential(const Vec3& z, const SubgoalQuery& q, const local::LocalParams& P) {
  const double rr = P.robot.radius_m;
  TermValue u;
  switch (P.method) {
    case Method::kClassic: u += local::classicAttraction(z, q.target, P.classic.xi); break;
    case Method::kTian2016:
      u += local::tianAttraction(z, q.velocity, q.acceleration, q.target, q.line_a, q.line_b, P.tian2016);
      break;
    case Method::kWang2014: u += local::classicAttraction(z, q.target, P.wang2014.k_att); break;
    case Method::kVff:
    case Method::kCvff: u += local::cvffAttraction(z, q.target, P.vff.K_p); break;
    case Method::kUuv: u += local::boundedAttraction(z, q.target, P.uuv.k_att, P.uuv.conic_distance_m); break;
  }
  forEachObstacle(z, q, rr, [&](const Proximity& p, const Vec3& v_rel, const Vec3& a_rel) {
    switch (P.method) {
      case Method::kClassic: u += local::classicRepulsion(p, P.classic.eta, P.classic.rho0_m); break;
      case Method::kTian2016: u += local::tianRepulsion(p, v_rel, a_rel, P.tian2016); break;
      case Method::kWang2014:
        u += local::goalAwareRepulsion(p, z, q.target, P.wang2014.K_2, P.wang2014.sensing_radius_m, P.wang2014.n);
        break;
      case Method::kVff:
      case Method::kCvff: u += local::vffRepulsion(p, P.vff.M_p, P.vff.p0_m); break;
      case Method::kUuv: u += local::goalAwareRepulsion(p, z, q.target, P.uuv.k_rep, P.uuv.rho0_m, 2.0); break;
    }
  });
  return u.u;
}

SubgoalChoice selectSubgoal(const SubgoalQuery& q, const local::LocalParams& P, const SubgoalParams& params) {
  SubgoalChoice c;
  c.subgoal = q.position;
  if (Status s = params.validate(); !s.ok()) {
    c.message = s.message();
    return c;
  }
  if (Status s = P.validate(); !s.ok()) {
    c.message = "sub-goal selector: " + s.message();
    return c;
  }
  if (!finiteQuery(q)) {
    c.message = "sub-goal selector: the robot state, target, line or an obstacle is not finite";
    return c;
  }
  c.r_outer_m = P.robot.v_max_mps * params.t0_s;
  c.r_inner_m = params.inner_ratio * c.r_outer_m;
  const double rr = P.robot.radius_m;
  c.nearest_obstacle_m = std::numeric_limits<double>::infinity();
  forEachObstacle(q.position, q, rr,
                  [&](const Proximity& p, const Vec3&, const Vec3&) { c.nearest_obstacle_m = std::min(c.nearest_obstacle_m, p.rho); });

  Vec3 to_target = q.target - q.position;
  if (params.planar) to_target.z() = 0.0;
  const double dist = to_target.norm();
  if (dist <= c.r_outer_m) {
    c.outcome = SubgoalOutcome::kTargetNear;
    c.subgoal = q.target;
    c.potential = c.straight_potential = subgoalPotential(c.subgoal, q, P);
    c.message = "the target is within one period's reach";
    return c;
  }
  const Vec3 dir = to_target / dist;
  const Vec3 straight = q.position + c.r_outer_m * dir;
  c.subgoal = straight;
  c.potential = c.straight_potential = subgoalPotential(straight, q, P);
  const double rho0 = influenceDistance(P);
  if (c.nearest_obstacle_m > rho0) {
    c.outcome = SubgoalOutcome::kStraight;
    c.message = "farther than rho0 from every obstacle: on the line at the outer radius";
    return c;
  }

  // z is (x, y) in planar mode, (x, y, z) otherwise.
  const int dim = params.planar ? 2 : 3;
  auto toPoint = [&](const VectorX& z) {
    Vec3 p = q.position;
    p.head(dim) = z;
    return p;
  };
  const VectorX centre = q.position.head(dim);
  const FeasibleSet annulus = FeasibleSet::annulus(centre, c.r_inner_m, c.r_outer_m);
  FeasibleSet omega = annulus;
  if (q.field)
    omega.contains = [&](const VectorX& z) { return annulus.holds(z) && q.field->distance(toPoint(z)) >= rr; };
  Objective f;
  f.value = [&](const VectorX& z) { return subgoalPotential(toPoint(z), q, P); };
  const VectorX z0 = (q.position + 0.5 * (c.r_inner_m + c.r_outer_m) * dir).head(dim);
  if (!omega.holds(z0)) {
    c.outcome = SubgoalOutcome::kStraightKept;
    c.message = "the annulus' mid-point toward the target is in rock; straight choice kept";
    return c;
  }
  c.optimization = minimizeGeneticTrustRegion(f, omega, z0, params.optimizer);
  const OptimizationResult& o = c.optimization;
  if (o.outcome != OptimizationOutcome::kInvalidInput && std::isfinite(o.value) && o.value < c.straight_potential &&
      omega.holds(o.z)) {
    c.outcome = SubgoalOutcome::kOptimized;
    c.subgoal = toPoint(o.z);
    c.potential = o.value;
    std::ostringstream m;
    m << "annulus minimum of U = " << o.value << " (straight " << c.straight_potential << "), "
      << optimizationOutcomeName(o.outcome) << " after " << o.iterations << " iterations";
    c.message = m.str();
  } else {
    c.outcome = SubgoalOutcome::kStraightKept;
    c.message = std::string("no point of the annulus lower than the straight choice (") +
                optimizationOutcomeName(o.outcome) + ")";
  }
  return c;
}

local::SubgoalPick pickSubgoal(const local::RobotState& state, const Vec3& line_a, const Vec3& line_b,
                               const std::vector<map::MovingObstacle>* moving,
                               const std::vector<local::StaticSphere>* static_obstacles,
                               const map::DistanceField* field, const local::LocalParams& local,
                               const SubgoalParams& params) {
  SubgoalQuery q;
  q.position = state.position;
  q.velocity = state.velocity;
  q.acceleration = state.acceleration;
  q.target = line_b;
  q.line_a = line_a;
  q.line_b = line_b;
  q.static_obstacles = static_obstacles;
  q.moving = moving;
  q.field = field;
  const SubgoalChoice c = selectSubgoal(q, local, params);
  local::SubgoalPick pick;
  pick.kind = subgoalOutcomeName(c.outcome);
  if (c.outcome == SubgoalOutcome::kInvalidInput) return pick;
  pick.point = c.subgoal;
  const Vec3 bearing = c.subgoal - state.position;
  const double reach = bearing.norm();
  pick.aim = reach > 1e-9 ? Vec3(state.position + bearing * (std::max(reach, (line_b - state.position).norm()) / reach))
                          : c.subgoal;
  return pick;
}

local::SubgoalFn subgoalFunction(const local::LocalParams& local, const SubgoalParams& params) {
  return [local, params](const local::SubgoalRequest& rq) {
    return pickSubgoal(*rq.state, rq.segment_a, rq.segment_b, rq.moving, rq.static_obstacles, rq.field, local, params);
  };
}

}  // namespace adit::fusion
