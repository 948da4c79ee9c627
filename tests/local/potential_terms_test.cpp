// SPDX-License-Identifier: BSD-3-Clause
// Each potential term against a central-difference gradient of its own potential (GTSAM style),
// plus signs, the fuzzy rule table at its centres, field-of-view edges and the 3-D rotation side.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "adit/local/potential_terms.hpp"

namespace adit::local {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 numericGradient(const std::function<double(const Vec3&)>& f, const Vec3& x, double h = 1e-6) {
  Vec3 g;
  for (int i = 0; i < 3; ++i) {
    Vec3 a = x, b = x;
    a[i] += h;
    b[i] -= h;
    g[i] = (f(a) - f(b)) / (2 * h);
  }
  return g;
}

void expectNear(const Vec3& analytic, const Vec3& numeric, double tol) {
  EXPECT_LT((analytic - numeric).norm(), tol * std::max(1.0, numeric.norm())) << "analytic " << analytic.transpose()
                                                                            << " numeric " << numeric.transpose();
}

// Random configurations around a sphere obstacle, inside its influence range.
struct Config {
  Vec3 q, v, a, centre, goal;
};
std::vector<Config> configs() {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Config> out;
  while (out.size() < 40) {
    Config c;
    c.centre = Vec3(2, 1, 0.5);
    c.q = c.centre + Vec3(u(rng), u(rng), u(rng)) * 1.6;
    const double d = (c.q - c.centre).norm();
    if (d < 0.8 || d > 2.2) continue;  // rho in (0.2, 1.6): inside rho0 = 2, off the clamp
    c.v = Vec3(u(rng), u(rng), u(rng));
    c.a = Vec3(u(rng), u(rng), u(rng)) * 0.5;
    c.goal = Vec3(8, 5, 1);
    out.push_back(c);
  }
  return out;
}
constexpr double kObR = 0.4, kRobR = 0.2;

TEST(PotentialTerms, ClassicGradients) {
  for (const Config& c : configs()) {
    auto att = [&](const Vec3& q) { return classicAttraction(q, c.goal, 1.5).u; };
    expectNear(classicAttraction(c.q, c.goal, 1.5).dq, numericGradient(att, c.q), 1e-6);
    auto rep = [&](const Vec3& q) { return classicRepulsion(sphereProximity(q, c.centre, kObR, kRobR), 0.7, 2.0).u; };
    expectNear(classicRepulsion(sphereProximity(c.q, c.centre, kObR, kRobR), 0.7, 2.0).dq, numericGradient(rep, c.q),
               1e-5);
  }
}

TEST(PotentialTerms, ClassicSigns) {
  const Vec3 q(0, 0, 0), centre(1, 0, 0);
  EXPECT_LT(classicAttraction(q, Vec3(5, 0, 0), 1.0).force().x(), 0.0 + 1e9);  // toward goal:
  EXPECT_GT(classicAttraction(q, Vec3(5, 0, 0), 1.0).force().x(), 0.0);
  EXPECT_LT(classicRepulsion(sphereProximity(q, centre, 0.3, 0.2), 1.0, 2.0).force().x(), 0.0);  // away
  EXPECT_EQ(classicRepulsion(sphereProximity(q, Vec3(5, 0, 0), 0.3, 0.2), 1.0, 2.0).u, 0.0);     // beyond rho0
}

TEST(PotentialTerms, TianAttractionGradientsInQVA) {
  Tian2016Params p;
  p.s = 2.5;
  p.l = 1.5;
  const Vec3 seg_a(0, 0, 0), seg_b(10, 0, 0);
  for (const Config& c : configs()) {
    auto fq = [&](const Vec3& q) { return tianAttraction(q, c.v, c.a, c.goal, seg_a, seg_b, p).u; };
    auto fv = [&](const Vec3& v) { return tianAttraction(c.q, v, c.a, c.goal, seg_a, seg_b, p).u; };
    auto fa = [&](const Vec3& a) { return tianAttraction(c.q, c.v, a, c.goal, seg_a, seg_b, p).u; };
    const TermValue t = tianAttraction(c.q, c.v, c.a, c.goal, seg_a, seg_b, p);
    expectNear(t.dq, numericGradient(fq, c.q), 1e-5);
    expectNear(t.dv, numericGradient(fv, c.v), 1e-5);
    expectNear(t.da, numericGradient(fa, c.a), 1e-5);
  }
}

TEST(PotentialTerms, TianLineFieldPullsBackOntoThePath) {
  Tian2016Params p;
  p.k_q = 0.0;
  const TermValue t = tianAttraction(Vec3(5, 2, 0), Vec3::Zero(), Vec3::Zero(), Vec3(10, 0, 0), Vec3(0, 0, 0),
                                     Vec3(10, 0, 0), p);
  EXPECT_LT(t.force().y(), 0.0);
  EXPECT_NEAR(t.force().x(), 0.0, 1e-12);
}

TEST(PotentialTerms, TianRepulsionGradientsWithRelativeMotion) {
  Tian2016Params p;
  int closing_with_accel = 0;
  for (const Config& c : configs()) {
    auto prox = [&](const Vec3& q) { return sphereProximity(q, c.centre, kObR, kRobR); };
    const Proximity p0 = prox(c.q);
    const double v_ro = c.v.dot(p0.toward()), a_ro = c.a.dot(p0.toward());
    if (std::abs(v_ro) < 1e-3 || std::abs(a_ro) < 1e-3) continue;  // the piecewise seams
    closing_with_accel += v_ro > 0 && a_ro > 0;
    auto fq = [&](const Vec3& q) { return tianRepulsion(prox(q), c.v, c.a, p).u; };
    auto fv = [&](const Vec3& v) { return tianRepulsion(p0, v, c.a, p).u; };
    auto fa = [&](const Vec3& a) { return tianRepulsion(p0, c.v, a, p).u; };
    const TermValue t = tianRepulsion(p0, c.v, c.a, p);
    expectNear(t.dq, numericGradient(fq, c.q, 1e-7), 1e-4);
    expectNear(t.dv, numericGradient(fv, c.v), 1e-5);
    expectNear(t.da, numericGradient(fa, c.a), 1e-5);
  }
  EXPECT_GT(closing_with_accel, 3);
}

TEST(PotentialTerms, TianRepulsionClosingPushesHarder) {
  Tian2016Params p;
  const Proximity prox = sphereProximity(Vec3::Zero(), Vec3(1, 0, 0), 0.3, 0.2);
  const double still = tianRepulsion(prox, Vec3::Zero(), Vec3::Zero(), p).force().x();
  const double closing = tianRepulsion(prox, Vec3(0.5, 0, 0), Vec3::Zero(), p).force().x();
  EXPECT_LT(still, 0.0);
  EXPECT_LT(closing, still);
  p.position_term_always = false;
  EXPECT_EQ(tianRepulsion(prox, Vec3(-0.5, 0, 0), Vec3::Zero(), p).u, 0.0);  // receding: nothing
}

TEST(PotentialTerms, GoalAwareRepulsionGradientAndGoalIsTheMinimum) {
  for (double n : {1.0, 2.0, 3.0}) {
    for (const Config& c : configs()) {
      auto f = [&](const Vec3& q) {
        return goalAwareRepulsion(sphereProximity(q, c.centre, kObR, kRobR), q, c.goal, 0.8, 2.0, n).u;
      };
      expectNear(goalAwareRepulsion(sphereProximity(c.q, c.centre, kObR, kRobR), c.q, c.goal, 0.8, 2.0, n).dq,
                 numericGradient(f, c.q), 1e-5);
    }
  }
  // A goal next to an obstacle: the repulsion vanishes there (Ge-Cui), so the goal stays reachable.
  const Vec3 goal(1.0, 0, 0), centre(1.8, 0, 0);
  EXPECT_EQ(goalAwareRepulsion(sphereProximity(goal, centre, 0.3, 0.2), goal, goal, 1.0, 2.0, 2.0).u, 0.0);
}

TEST(PotentialTerms, ShrinkingInfluenceRange) {
  EXPECT_EQ(shrinkingInfluenceRange(10.0, 2.0), 2.0);
  EXPECT_EQ(shrinkingInfluenceRange(1.5, 2.0), 1.5);
}

TEST(PotentialTerms, FuzzyGainAtEveryRuleCentreIsThatRulesOutput) {
  const double range = 4.0, half = 60.0 * kPi / 180.0;
  for (int d = 0; d < 4; ++d)
    for (int b = 0; b < 5; ++b) {
      const double g = fuzzyRepulsionGain(fuzzyDistanceCentre(d, range), fuzzyBearingCentre(b, half), range, half);
      int nearest = 0;
      for (int k = 1; k < 4; ++k)
        if (std::abs(g - fuzzyOutputCentre(k)) < std::abs(g - fuzzyOutputCentre(nearest))) nearest = k;
      EXPECT_EQ(nearest, fuzzyRule(d, b)) << "d set " << d << ", bearing set " << b << ": gain " << g;
    }
  // Symmetric in the bearing, larger when nearer and more ahead.
  EXPECT_NEAR(fuzzyRepulsionGain(1.0, 0.3, range, half), fuzzyRepulsionGain(1.0, -0.3, range, half), 1e-12);
  EXPECT_GT(fuzzyRepulsionGain(0.5, 0.0, range, half), fuzzyRepulsionGain(3.0, 0.0, range, half));
  EXPECT_GT(fuzzyRepulsionGain(1.0, 0.0, range, half), fuzzyRepulsionGain(1.0, half, range, half));
  EXPECT_EQ(fuzzyRepulsionGain(std::nan(""), 0.0, range, half), 0.0);
}

TEST(PotentialTerms, FieldOfViewEdges) {
  const Vec3 q = Vec3::Zero(), heading = Vec3::UnitX();
  const double half = 60.0 * kPi / 180.0;
  auto at = [](double r, double deg) { return Vec3(r * std::cos(deg * kPi / 180), r * std::sin(deg * kPi / 180), 0); };
  EXPECT_TRUE(inFieldOfView(q, heading, at(2, 0), 4, half));
  EXPECT_TRUE(inFieldOfView(q, heading, at(2, 59.9), 4, half));
  EXPECT_TRUE(inFieldOfView(q, heading, at(2, -59.9), 4, half));
  EXPECT_FALSE(inFieldOfView(q, heading, at(2, 60.1), 4, half));
  EXPECT_FALSE(inFieldOfView(q, heading, at(2, 180), 4, half));
  EXPECT_TRUE(inFieldOfView(q, heading, at(4.0, 10), 4, half));
  EXPECT_FALSE(inFieldOfView(q, heading, at(4.01, 10), 4, half));
}

TEST(PotentialTerms, VffAndCvffTerms) {
  for (const Config& c : configs()) {
    auto f = [&](const Vec3& q) { return vffRepulsion(sphereProximity(q, c.centre, kObR, kRobR), 5.0, 2.0).u; };
    expectNear(vffRepulsion(sphereProximity(c.q, c.centre, kObR, kRobR), 5.0, 2.0).dq, numericGradient(f, c.q), 1e-5);
    auto g = [&](const Vec3& q) { return cvffAttraction(q, c.goal, 13.0).u; };
    expectNear(cvffAttraction(c.q, c.goal, 13.0).dq, numericGradient(g, c.q), 1e-6);
  }
  // Velocity repulsion: sideways and away while closing, nothing while receding.
  const Proximity p = sphereProximity(Vec3::Zero(), Vec3(1, 0.3, 0), 0.3, 0.1);
  const Vec3 f = cvffVelocityRepulsion(p, Vec3(1, 0, 0), 7.0, 1.0);
  EXPECT_NEAR(f.x(), 0.0, 1e-12);
  EXPECT_LT(f.y(), 0.0);
  EXPECT_EQ(cvffVelocityRepulsion(p, Vec3(-1, 0, 0), 7.0, 1.0), Vec3::Zero());
  EXPECT_NEAR(cvffVelocityAttraction(Vec3(0.5, 0, 0), 15.0, 1.0).x(), 7.5, 1e-12);
}

TEST(PotentialTerms, BoundedAttractionIsConicFarAway) {
  for (const Config& c : configs()) {
    for (double dc : {0.5, 50.0}) {
      auto f = [&](const Vec3& q) { return boundedAttraction(q, c.goal, 1.2, dc).u; };
      expectNear(boundedAttraction(c.q, c.goal, 1.2, dc).dq, numericGradient(f, c.q), 1e-6);
    }
  }
  EXPECT_NEAR(boundedAttraction(Vec3(100, 0, 0), Vec3::Zero(), 1.0, 5.0).force().norm(), 5.0, 1e-12);
  EXPECT_NEAR(boundedAttraction(Vec3(2, 0, 0), Vec3::Zero(), 1.0, 5.0).force().norm(), 2.0, 1e-12);
}

TEST(PotentialTerms, RotationSideIn3D) {
  // Obstacle ahead and above: d points up (its side), the vehicle turns down (-d).
  const Vec3 a(1, 0, 0);
  Vec3 d = rotationSide(a, Vec3(5, 0, 0.5));
  EXPECT_NEAR(d.dot(a), 0.0, 1e-12);
  EXPECT_GT(d.z(), 0.0);
  EXPECT_NEAR(d.y(), 0.0, 1e-12);
  // Ahead and to the left (+y): d points left.
  d = rotationSide(a, Vec3(5, 0.5, 0));
  EXPECT_GT(d.y(), 0.0);
  // Ahead, right and below, with a climbing velocity: still perpendicular, toward the obstacle.
  const Vec3 a2(1, 0, 0.5), b2(4, -1, -0.5);
  d = rotationSide(a2, b2);
  EXPECT_NEAR(d.dot(a2), 0.0, 1e-12);
  EXPECT_GT(d.dot(b2), 0.0);
  // Head-on: no preferred side.
  EXPECT_EQ(rotationSide(a, Vec3(3, 0, 0)), Vec3::Zero());
}

TEST(Params, PresetsValidateAndBadValuesAreNamed) {
  for (Method m : {Method::kClassic, Method::kTian2016, Method::kWang2014, Method::kVff, Method::kCvff, Method::kUuv})
    EXPECT_TRUE(LocalParams::preset(m).validate().ok()) << methodName(m);
  LocalParams p = LocalParams::preset(Method::kTian2016);
  p.tian2016.rho0_m = -1;
  const Status s = p.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("Tian2016Params::rho0_m = -1"), std::string::npos) << s.message();
  p = LocalParams::preset(Method::kClassic);
  p.robot.v_max_mps = std::nan("");
  EXPECT_FALSE(p.validate().ok());
  EXPECT_FALSE(parseMethod("khatib").ok());
  EXPECT_EQ(*parseMethod("cvff"), Method::kCvff);
}

}  // namespace
}  // namespace adit::local
