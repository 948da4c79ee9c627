// SPDX-License-Identifier: BSD-3-Clause
#include "adit/local/potential_terms.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace adit::local {

namespace {
constexpr double kMinRho = 1e-3;  // contact: keeps 1/rho finite
constexpr double kInf = std::numeric_limits<double>::infinity();

// d(n)/dq applied to w, n = unit(pivot - q): -(w - n (n.w)) / |pivot - q|.
Vec3 directionDerivative(const Proximity& p, const Vec3& w) {
  if (!(p.pivot_distance > 1e-9) || !std::isfinite(p.pivot_distance)) return Vec3::Zero();
  const Vec3 n = p.toward();
  return -(w - n * n.dot(w)) / p.pivot_distance;
}
}  // namespace

Proximity sphereProximity(const Vec3& q, const Vec3& centre, double obstacle_radius, double robot_radius) {
  Proximity p;
  const Vec3 d = q - centre;
  const double dist = d.norm();
  p.grad = dist > 1e-12 ? Vec3(d / dist) : Vec3::UnitX();
  p.rho = dist - obstacle_radius - robot_radius;
  p.pivot_distance = dist;
  return p;
}

Proximity pointProximity(const Vec3& q, const Vec3& point, double robot_radius) {
  return sphereProximity(q, point, 0.0, robot_radius);
}

double powNorm(const Vec3& x, double e, Vec3* grad) {
  const double r = x.norm();
  if (r <= 0.0) {
    if (grad) grad->setZero();
    return e == 0.0 ? 1.0 : 0.0;
  }
  const double re = std::pow(r, e);
  if (grad) *grad = e * re / (r * r) * x;
  return re;
}

TermValue classicAttraction(const Vec3& q, const Vec3& goal, double xi) {
  TermValue t;
  const Vec3 d = q - goal;
  t.u = 0.5 * xi * d.squaredNorm();
  t.dq = xi * d;
  return t;
}

TermValue classicRepulsion(const Proximity& p, double eta, double rho0) {
  TermValue t;
  if (p.rho > rho0) return t;
  const double rho = std::max(p.rho, kMinRho);
  const double k = 1.0 / rho - 1.0 / rho0;
  t.u = 0.5 * eta * k * k;
  t.dq = -eta * k / (rho * rho) * p.grad;
  return t;
}

Vec3 nearestOnSegment(const Vec3& q, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 <= 0.0) return a;
  const double s = std::clamp((q - a).dot(ab) / len2, 0.0, 1.0);
  return a + s * ab;
}

TermValue tianAttraction(const Vec3& q, const Vec3& v_rel, const Vec3& a_rel, const Vec3& goal,
                         const Vec3& seg_a, const Vec3& seg_b, const Tian2016Params& prm) {
  TermValue t;
  Vec3 g;
  t.u += prm.k_q * powNorm(q - goal, prm.s, &g);
  t.dq += prm.k_q * g;
  t.u += prm.k_v * powNorm(v_rel, prm.t, &g);
  t.dv += prm.k_v * g;
  t.u += prm.k_a * powNorm(a_rel, prm.p, &g);
  t.da += prm.k_a * g;
  if (prm.k_l > 0.0) {
    // The gradient of the distance to a convex set is the unit vector from its nearest point,
    // so differentiating with q_line held fixed is exact.
    const Vec3 q_line = nearestOnSegment(q, seg_a, seg_b);
    t.u += prm.k_l * powNorm(q - q_line, prm.l, &g);
    t.dq += prm.k_l * g;
    t.u += prm.k_l * powNorm(v_rel, prm.l, &g);
    t.dv += prm.k_l * g;
    t.u += prm.k_l * powNorm(a_rel, prm.l, &g);
    t.da += prm.k_l * g;
  }
  return t;
}

TermValue tianRepulsion(const Proximity& p, const Vec3& v_rel, const Vec3& a_rel, const Tian2016Params& prm) {
  TermValue t;
  if (p.rho >= prm.rho0_m) return t;
  const Vec3 n = p.toward();
  const double v_ro = v_rel.dot(n), a_ro = a_rel.dot(n);
  const bool closing = v_ro > 0.0;
  if (!closing && !prm.position_term_always) return t;
  const double rho = std::max(p.rho, kMinRho);
  t.u += prm.K_q * (1.0 / rho - 1.0 / prm.rho0_m);
  t.dq += -prm.K_q / (rho * rho) * p.grad;
  if (!closing) return t;
  t.u += prm.K_v * v_ro;
  t.dv += prm.K_v * n;
  t.dq += prm.K_v * directionDerivative(p, v_rel);
  if (a_ro > 0.0) {
    t.u += prm.K_a * a_ro;
    t.da += prm.K_a * n;
    t.dq += prm.K_a * directionDerivative(p, a_rel);
  }
  return t;
}

bool inFieldOfView(const Vec3& q, const Vec3& heading, const Vec3& point, double range, double half_angle_rad) {
  const Vec3 d = point - q;
  const double dist = d.norm();
  if (!(dist <= range)) return false;
  const double hn = heading.norm();
  if (hn <= 1e-12 || dist <= 1e-12) return true;
  const double c = d.dot(heading) / (dist * hn);
  return c >= std::cos(half_angle_rad) - 1e-12;
}

TermValue goalAwareRepulsion(const Proximity& p, const Vec3& q, const Vec3& goal, double K, double rho0, double n,
                             double goal_cap) {
  TermValue t;
  if (p.rho > rho0) return t;
  const double rho = std::max(p.rho, kMinRho);
  const double k = 1.0 / rho - 1.0 / rho0;
  Vec3 g_goal;
  double rg;
  if (goal_cap > 0.0 && (q - goal).norm() > goal_cap) {
    rg = std::pow(goal_cap, n);
    g_goal.setZero();
  } else {
    rg = powNorm(q - goal, n, &g_goal);
  }
  t.u = 0.5 * K * k * k * rg;
  t.dq = -K * k / (rho * rho) * rg * p.grad + 0.5 * K * k * k * g_goal;
  return t;
}

double shrinkingInfluenceRange(double goal_distance, double sensing_radius) {
  return goal_distance > sensing_radius ? sensing_radius : goal_distance;
}

// ---- fuzzy gain -------------------------------------------------------------------------------

namespace {
// Output sets N, S, M, L; rows ZD, SD, MD, FD; columns LS, LF, F, RF, RS.
constexpr int kRules[4][5] = {{2, 3, 3, 3, 2}, {1, 2, 3, 2, 1}, {0, 1, 2, 1, 0}, {0, 0, 1, 0, 0}};
constexpr double kOutCentre[4] = {0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0};
constexpr double kOutSigma = 1.0 / 6.0;
// The output universe extends beyond [0, 1] so that a lone L (or N) has its centroid at its centre.
constexpr double kUniverseLo = -0.5, kUniverseHi = 1.5;
constexpr int kSamples = 201;

double gauss(double x, double c, double sigma) {
  const double z = (x - c) / sigma;
  return std::exp(-0.5 * z * z);
}
}  // namespace

double fuzzyOutputCentre(int s) { return kOutCentre[std::clamp(s, 0, 3)]; }
int fuzzyRule(int d, int b) { return kRules[std::clamp(d, 0, 3)][std::clamp(b, 0, 4)]; }
double fuzzyDistanceCentre(int s, double range) { return range * double(std::clamp(s, 0, 3)) / 3.0; }
double fuzzyBearingCentre(int s, double half_angle) {
  return half_angle * (1.0 - 0.5 * double(std::clamp(s, 0, 4)));  // LS = +half (left) .. RS = -half
}

double fuzzyRepulsionGain(double d, double theta, double range, double half_angle) {
  if (!std::isfinite(d) || !std::isfinite(theta) || !(range > 0) || !(half_angle > 0)) return 0.0;
  d = std::clamp(d, 0.0, range);
  theta = std::clamp(theta, -half_angle, half_angle);
  double mu_d[4], mu_b[5];
  for (int i = 0; i < 4; ++i) mu_d[i] = gauss(d, fuzzyDistanceCentre(i, range), range / 6.0);
  for (int j = 0; j < 5; ++j) mu_b[j] = gauss(theta, fuzzyBearingCentre(j, half_angle), half_angle / 4.0);
  double strength[4] = {0, 0, 0, 0};  // per output set: max over rules of min(mu_d, mu_b)
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 5; ++j) {
      const int k = kRules[i][j];
      strength[k] = std::max(strength[k], std::min(mu_d[i], mu_b[j]));
    }
  // The output sets sampled once over the universe (the per-call cost is then min/max only).
  struct OutputTable {
    double y[kSamples];
    double mu[kSamples][4];
  };
  static const OutputTable table = [] {
    OutputTable t{};
    for (int s = 0; s < kSamples; ++s) {
      t.y[s] = kUniverseLo + (kUniverseHi - kUniverseLo) * double(s) / double(kSamples - 1);
      for (int k = 0; k < 4; ++k) t.mu[s][k] = gauss(t.y[s], kOutCentre[k], kOutSigma);
    }
    return t;
  }();
  double num = 0.0, den = 0.0;
  for (int s = 0; s < kSamples; ++s) {
    double mu = 0.0;
    for (int k = 0; k < 4; ++k) mu = std::max(mu, std::min(strength[k], table.mu[s][k]));
    num += mu * table.y[s];
    den += mu;
  }
  return den > 0.0 ? std::clamp(num / den, 0.0, 1.0) : 0.0;
}

// ---- Guo 2022 ---------------------------------------------------------------------------------

TermValue vffRepulsion(const Proximity& p, double M_p, double p0) {
  TermValue t;
  if (p.rho > p0) return t;
  const double rho = std::max(p.rho, kMinRho);
  t.u = M_p / rho;
  t.dq = -M_p / (rho * rho) * p.grad;
  return t;
}

TermValue cvffAttraction(const Vec3& q, const Vec3& goal, double K_p) {
  TermValue t;
  const Vec3 d = q - goal;
  const double r = d.norm();
  t.u = K_p * r;
  if (r > 0.0) t.dq = K_p * d / r;
  return t;
}

Vec3 cvffVelocityAttraction(const Vec3& v_rel_target, double K_v, double v_max) {
  if (!(v_max > 0.0)) return Vec3::Zero();
  return K_v * v_rel_target / v_max;
}

Vec3 cvffVelocityRepulsion(const Proximity& p, const Vec3& v_rel, double M_v, double p0) {
  if (p.rho > p0) return Vec3::Zero();
  const Vec3 n = p.toward();
  const double speed = v_rel.norm();
  if (speed <= 1e-12 || v_rel.dot(n) <= 0.0) return Vec3::Zero();
  const double rho = std::max(p.rho, kMinRho);
  const Vec3 u = v_rel / speed;
  Vec3 away = p.grad - u * u.dot(p.grad);  // component of "away" perpendicular to V_b
  const double an = away.norm();
  away = an > 1e-9 ? Vec3(away / an) : p.grad;
  return M_v * speed / rho * away;
}

// ---- UUV --------------------------------------------------------------------------------------

TermValue boundedAttraction(const Vec3& q, const Vec3& goal, double k, double dc) {
  TermValue t;
  const Vec3 d = q - goal;
  const double r = d.norm();
  if (r <= dc) {
    t.u = 0.5 * k * r * r;
    t.dq = k * d;
  } else {
    t.u = k * dc * r - 0.5 * k * dc * dc;
    t.dq = k * dc * d / r;
  }
  return t;
}

Vec3 rotationSide(const Vec3& a, const Vec3& b) {
  const Vec3 c = a.cross(b);
  if (c.norm() <= 1e-9 * std::max(1.0, a.norm() * b.norm())) return Vec3::Zero();
  return c.cross(a);
}

}  // namespace adit::local
