// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The attraction and repulsion terms of the four papers as pure functions (no state, no
/// allocation), so that tests can hold each force against a numerical gradient of its potential
/// and the fusion layer can minimise the same potential. Formulas: the papers' equations,
/// cited at each term (Tian 2016, Wang 2014, Guo 2022).
///
/// Each term returns its potential U and the gradients of U with respect to the robot's position
/// q, its (relative) velocity v and its (relative) acceleration a. The force is -(dq + dv + da)
/// (Tian 2016 eq. 10); terms that do not depend on v or a leave those gradients zero. Terms that
/// the papers define only as a force (the CVFF velocity fields, the UUV rotation direction) return
/// a force and no potential.
///
///   Proximity p = sphereProximity(q, centre, obstacle_radius, robot_radius);
///   TermValue rep = classicRepulsion(p, eta, rho0);
///   TermValue att = classicAttraction(q, goal, xi);
///   Vec3 f = att.force() + rep.force();

#include <Eigen/Core>

#include "adit/local/params.hpp"
#include "adit/map/types.hpp"

namespace adit::local {

using map::Vec3;

/// Potential and its gradients.
struct TermValue {
  double u = 0.0;
  Vec3 dq = Vec3::Zero();
  Vec3 dv = Vec3::Zero();
  Vec3 da = Vec3::Zero();
  Vec3 force() const { return -(dq + dv + da); }
  TermValue& operator+=(const TermValue& o) { u += o.u; dq += o.dq; dv += o.dv; da += o.da; return *this; }
};

/// How near an obstacle is: rho (robot surface to obstacle surface), its gradient with respect to
/// q (unit, away from the obstacle), and the distance to the point the direction turns about
/// (the sphere's centre, or the nearest point itself for a point obstacle; infinity for a plane).
/// That distance makes d(unit to obstacle)/dq exact for the relative-motion terms.
struct Proximity {
  double rho = 0.0;
  Vec3 grad = Vec3::UnitX();
  double pivot_distance = 0.0;
  /// Unit vector from the robot toward the obstacle (n = -grad).
  Vec3 toward() const { return -grad; }
};

/// A sphere (or a disc at the robot's height) of `obstacle_radius` at `centre`.
Proximity sphereProximity(const Vec3& q, const Vec3& centre, double obstacle_radius, double robot_radius);
/// A point on an obstacle surface (a rock voxel's nearest point, a box corner).
Proximity pointProximity(const Vec3& q, const Vec3& point, double robot_radius);

/// |x|^e and its gradient e |x|^(e-2) x (zero at x = 0 for e >= 1).
double powNorm(const Vec3& x, double e, Vec3* grad);

// ---- Classic (Khatib; Tian 2016 eqs. 1-8) ----------------------------------------------------

/// U = 1/2 xi |q - q_g|^2.
TermValue classicAttraction(const Vec3& q, const Vec3& goal, double xi);
/// U = 1/2 eta (1/rho - 1/rho0)^2 inside rho0, else 0. rho is clamped at 1 mm (contact).
TermValue classicRepulsion(const Proximity& p, double eta, double rho0);

// ---- Tian 2016 --------------------------------------------------------------------------------

/// Point of segment [a, b] nearest to q (the line field's q_line).
Vec3 nearestOnSegment(const Vec3& q, const Vec3& a, const Vec3& b);

/// Eq. 9: U = k_q |q - q_g|^s + k_v |v|^t + k_a |a|^p + k_l (|q - q_line|^l + |v|^l + |a|^l),
/// q_line the point of segment [seg_a, seg_b] nearest to q; v, a relative to the target.
TermValue tianAttraction(const Vec3& q, const Vec3& v_rel, const Vec3& a_rel, const Vec3& goal,
                         const Vec3& seg_a, const Vec3& seg_b, const Tian2016Params& prm);

/// Eq. 12: U = K_q (1/rho - 1/rho0) + K_v v_ro [+ K_a a_ro] inside rho0 while closing in
/// (v_ro > 0; the acceleration term while a_ro > 0 too), with v_ro = v_rel . n, a_ro = a_rel . n,
/// n the unit vector toward the obstacle; v_rel, a_rel the robot's motion relative to it. With
/// prm.position_term_always, the position term also applies when v_ro <= 0.
TermValue tianRepulsion(const Proximity& p, const Vec3& v_rel, const Vec3& a_rel, const Tian2016Params& prm);

// ---- Wang 2014 --------------------------------------------------------------------------------

/// True when `point` lies in the sector of radius `range` and +- half_angle_rad about `heading`
/// (unit or zero; a zero heading sees all around) centred at q. Bounds are inclusive.
bool inFieldOfView(const Vec3& q, const Vec3& heading, const Vec3& point, double range, double half_angle_rad);

/// Ge-Cui goal-aware repulsion: U = 1/2 K (1/rho - 1/rho0)^2 |q - q_g|^n inside rho0. With
/// `goal_cap` > 0 the goal distance in the factor is min(|q - q_g|, goal_cap) (constant, so no
/// pull toward the goal, beyond it).
TermValue goalAwareRepulsion(const Proximity& p, const Vec3& q, const Vec3& goal, double K, double rho0, double n,
                             double goal_cap = 0.0);

/// Shrinking influence range: r while the goal is farther than r, else the goal distance.
double shrinkingInfluenceRange(double goal_distance, double sensing_radius);

/// Wang 2014's fuzzy repulsion gain f(theta, d) in [0, 1]: Gaussian memberships for d over
/// [0, range] (ZD, SD, MD, FD) and theta over +-half_angle (LS, LF, F, RF, RS), the paper's rule
/// table, min inference, max aggregation, centroid of the output sets (N, S, M, L) over [0, 1].
/// theta > 0 is to the left of the heading.
double fuzzyRepulsionGain(double d, double theta_rad, double range, double half_angle_rad);
/// Centres of the output sets N, S, M, L and the rule table (row d: ZD..FD, column theta:
/// LS, LF, F, RF, RS), for tests and documentation.
double fuzzyOutputCentre(int output_set);
int fuzzyRule(int distance_set, int bearing_set);
double fuzzyDistanceCentre(int set, double range);
double fuzzyBearingCentre(int set, double half_angle_rad);

// ---- Guo 2022 VFF / CVFF ----------------------------------------------------------------------

/// VFF cell repulsion (eq. 4): force M_p C / rho^2 away from the cell, C = 1 within p0. Its
/// potential is U = M_p / rho (exact gradient; the paper gives the force only).
TermValue vffRepulsion(const Proximity& p, double M_p, double p0);
/// CVFF position attraction (eq. 9): F = K_p unit(q_g - q), the gradient of U = K_p |q - q_g|.
TermValue cvffAttraction(const Vec3& q, const Vec3& goal, double K_p);
/// CVFF velocity attraction (eqs. 11-12), force only: K_v V_g / v_max with V_g the robot's
/// velocity relative to the target. Interpretation: scaled by v_max so it is at most K_v.
Vec3 cvffVelocityAttraction(const Vec3& v_rel_target, double K_v, double v_max);
/// CVFF velocity repulsion (eq. 7), force only. Interpretation (the OCR garbles the direction):
/// while closing in, magnitude M_v |V_b| C / rho, directed perpendicular to V_b away from the
/// obstacle (straight away when head-on); zero when receding or beyond p0.
Vec3 cvffVelocityRepulsion(const Proximity& p, const Vec3& v_rel, double M_v, double p0);

// ---- UUV --------------------------------------------------------------------------------------

/// Quadratic within conic_distance, conic (constant magnitude k d*) beyond; C1 at the seam.
TermValue boundedAttraction(const Vec3& q, const Vec3& goal, double k, double conic_distance);
/// Eqs. 7-8: c = a x b, d = c x a, with a the velocity and b the vector to the obstacle. d is
/// perpendicular to a, pointing to the obstacle's side; the vehicle turns toward -d. Zero when a
/// and b are parallel (no preferred side).
Vec3 rotationSide(const Vec3& velocity, const Vec3& to_obstacle);

}  // namespace adit::local
