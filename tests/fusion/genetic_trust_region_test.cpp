// SPDX-License-Identifier: BSD-3-Clause
// The genetic trust-region method on analytic functions with known minima: Rosenbrock, a minimum
// outside the feasible annulus, and a multi-modal objective whose trust region stalls on Ω's
// boundary until the genetic restart escapes; plus the paper's rules checked on the iteration log
// (trust region obeyed, acceptance by the ratio test, radius bands of eq. 17).
#include "adit/fusion/genetic_trust_region.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace adit::fusion {
namespace {

using Vec2 = Eigen::Vector2d;

VectorX v2(double x, double y) { return Vec2(x, y); }

Objective rosenbrock(bool with_gradient) {
  Objective f;
  f.value = [](const VectorX& z) { return 100 * std::pow(z[1] - z[0] * z[0], 2) + std::pow(1 - z[0], 2); };
  if (with_gradient)
    f.gradient = [](const VectorX& z) {
      return v2(-400 * z[0] * (z[1] - z[0] * z[0]) - 2 * (1 - z[0]), 200 * (z[1] - z[0] * z[0]));
    };
  return f;
}

TEST(GeneticTrustRegion, RosenbrockWithAnalyticGradient) {
  GeneticTrustRegionParams p;
  const OptimizationResult r = minimizeGeneticTrustRegion(rosenbrock(true), {}, v2(-1.2, 1.0), p);
  EXPECT_EQ(r.outcome, OptimizationOutcome::kConverged) << r.message;
  EXPECT_NEAR(r.z[0], 1.0, 1e-5);
  EXPECT_NEAR(r.z[1], 1.0, 1e-5);
  EXPECT_LT(r.value, 1e-10);
  EXPECT_LT(r.iterations, 200);
}

TEST(GeneticTrustRegion, RosenbrockWithNumericalGradient) {
  GeneticTrustRegionParams p;
  p.eps1 = 1e-5;
  const OptimizationResult r = minimizeGeneticTrustRegion(rosenbrock(false), {}, v2(-1.2, 1.0), p);
  EXPECT_EQ(r.outcome, OptimizationOutcome::kConverged) << r.message;
  EXPECT_NEAR(r.z[0], 1.0, 1e-4);
  EXPECT_NEAR(r.z[1], 1.0, 1e-4);
}

TEST(GeneticTrustRegion, LogObeysTheTrustRegionTheRatioTestAndTheRadiusBands) {
  GeneticTrustRegionParams p;
  const OptimizationResult r = minimizeGeneticTrustRegion(rosenbrock(true), {}, v2(-1.2, 1.0), p);
  ASSERT_FALSE(r.log.empty());
  double delta = p.delta0;
  int accepted = 0, rejected = 0;
  for (const IterationRecord& rec : r.log) {
    ASSERT_EQ(rec.event, IterationRecord::Event::kStep);
    EXPECT_LE(rec.step_norm, delta * (1 + 1e-9)) << "k = " << rec.k;      // |d| <= Δ (eq. 14)
    EXPECT_EQ(rec.accepted, rec.ratio > p.eta1) << "k = " << rec.k;      // eq. 16
    accepted += rec.accepted;
    rejected += !rec.accepted;
    // eq. 17 bands for the new radius
    if (rec.ratio > p.eta2) {
      EXPECT_GE(rec.delta, delta * (1 - 1e-12));
      EXPECT_LE(rec.delta, std::min(p.delta_max, p.beta3 * delta) * (1 + 1e-12));
    } else if (rec.ratio >= p.eta1) {
      EXPECT_GE(rec.delta, p.beta2 * delta * (1 - 1e-12));
      EXPECT_LE(rec.delta, delta * (1 + 1e-12));
    } else {
      EXPECT_GE(rec.delta, p.beta1 * delta * (1 - 1e-12));
      EXPECT_LE(rec.delta, p.beta2 * delta * (1 + 1e-12));
    }
    delta = rec.delta;
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(rejected, 0);  // Rosenbrock's valley makes some steps fail
}

TEST(GeneticTrustRegion, MinimumOutsideTheAnnulusEndsOnItsInnerCircle) {
  // U = |z - (0.3, 0)|^2 has its minimum inside the inner circle of the annulus R in [0.6, 1]
  // around the origin: the constrained minimum is (0.6, 0).
  Objective f;
  f.value = [](const VectorX& z) { return (z - v2(0.3, 0.0)).squaredNorm(); };
  const FeasibleSet omega = FeasibleSet::annulus(v2(0, 0), 0.6, 1.0);
  GeneticTrustRegionParams p;
  p.ga_radius = 1.0;
  const OptimizationResult r = minimizeGeneticTrustRegion(f, omega, v2(-0.2, -0.8), p);
  ASSERT_NE(r.outcome, OptimizationOutcome::kInvalidInput) << r.message;
  ASSERT_NE(r.outcome, OptimizationOutcome::kMaxIterations) << r.message;
  EXPECT_TRUE(omega.holds(r.z));
  EXPECT_NEAR(r.z[0], 0.6, 2e-3);
  EXPECT_NEAR(r.z[1], 0.0, 2e-2);
  for (const IterationRecord& rec : r.log) EXPECT_TRUE(omega.holds(rec.z)) << "k = " << rec.k;
}

/// Two wells: a shallow one just outside the annulus' outer circle (the trust region runs into the
/// boundary there and stalls with a non-zero gradient) and a deeper one inside the annulus on the
/// far side.
Objective twoWells() {
  Objective f;
  f.value = [](const VectorX& z) {
    return -3.0 * std::exp(-(z - v2(3.6, 0.0)).squaredNorm()) - 6.0 * std::exp(-(z - v2(-2.5, 0.0)).squaredNorm()) +
           0.01 * z.squaredNorm();
  };
  return f;
}

TEST(GeneticTrustRegion, PlainTrustRegionStallsOnTheBoundaryAndTheGeneticRestartEscapes) {
  const FeasibleSet omega = FeasibleSet::annulus(v2(0, 0), 2.0, 3.0);
  GeneticTrustRegionParams plain;
  plain.max_restarts = 0;  // the trust region alone
  const OptimizationResult stalled = minimizeGeneticTrustRegion(twoWells(), omega, v2(2.5, 0.5), plain);
  EXPECT_EQ(stalled.outcome, OptimizationOutcome::kStagnated) << stalled.message;
  EXPECT_NEAR(stalled.z.norm(), 3.0, 1e-3);  // stuck on the outer circle near the shallow well
  EXPECT_GT(stalled.z[0], 2.5);
  EXPECT_GT(stalled.grad_norm, 0.1);         // not a stationary point: a stall

  GeneticTrustRegionParams hybrid;
  hybrid.ga_radius = 6.0;  // the neighbourhood spans the annulus
  const OptimizationResult escaped = minimizeGeneticTrustRegion(twoWells(), omega, v2(2.5, 0.5), hybrid);
  EXPECT_EQ(escaped.outcome, OptimizationOutcome::kConverged) << escaped.message;
  EXPECT_GE(escaped.restarts, 1);
  EXPECT_NEAR(escaped.z[0], -2.5, 0.05);
  EXPECT_NEAR(escaped.z[1], 0.0, 1e-3);
  EXPECT_LT(escaped.value, stalled.value - 3.0);
  bool jumped = false;
  for (const IterationRecord& rec : escaped.log) jumped |= rec.event == IterationRecord::Event::kGeneticJump;
  EXPECT_TRUE(jumped);
}

TEST(GeneticTrustRegion, SameSeedSameResultAndLog) {
  const FeasibleSet omega = FeasibleSet::annulus(v2(0, 0), 2.0, 3.0);
  GeneticTrustRegionParams p;
  p.ga_radius = 6.0;
  const OptimizationResult a = minimizeGeneticTrustRegion(twoWells(), omega, v2(2.5, 0.5), p);
  const OptimizationResult b = minimizeGeneticTrustRegion(twoWells(), omega, v2(2.5, 0.5), p);
  ASSERT_EQ(a.log.size(), b.log.size());
  EXPECT_EQ(a.z, b.z);
  for (std::size_t i = 0; i < a.log.size(); ++i) EXPECT_EQ(a.log[i].z, b.log[i].z);
  EXPECT_EQ(a.evaluations, b.evaluations);
}

TEST(GeneticTrustRegion, GeneticSearchIsNeverWorseThanItsCentreAndStaysInOmegaAndTheBall) {
  const FeasibleSet omega = FeasibleSet::annulus(v2(0, 0), 2.0, 3.0);
  GeneticTrustRegionParams p;
  p.ga_radius = 1.5;
  const Objective f = twoWells();
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const VectorX centre = v2(2.0 * std::cos(0.3 * seed), 2.5 * std::sin(0.3 * seed)).normalized() * 2.5;
    int evals = 0;
    const VectorX best = geneticSearch(f.value, omega, centre, p, seed, &evals);
    EXPECT_LE(f.value(best), f.value(centre));
    EXPECT_TRUE(omega.holds(best));
    EXPECT_LE((best - centre).norm(), p.ga_radius * (1 + 1e-9));
    EXPECT_EQ(evals, p.ga_population * (p.ga_generations + 1) - p.ga_elite * p.ga_generations);
  }
}

TEST(GeneticTrustRegion, NaNRegionIsNeverEntered) {
  Objective f;
  f.value = [](const VectorX& z) { return z[0] > 1.0 ? std::nan("") : (z - v2(3, 0)).squaredNorm(); };
  f.gradient = [](const VectorX& z) { return VectorX(2 * (z - v2(3, 0))); };
  GeneticTrustRegionParams p;
  p.max_iterations = 200;
  const OptimizationResult r = minimizeGeneticTrustRegion(f, {}, v2(0, 0), p);
  EXPECT_TRUE(std::isfinite(r.value));
  EXPECT_LE(r.z[0], 1.0);
  EXPECT_GT(r.z[0], 0.99);  // pressed against the edge of the defined region
}

TEST(GeneticTrustRegion, InvalidInputIsReportedNotThrown) {
  const FeasibleSet omega = FeasibleSet::annulus(v2(0, 0), 0.6, 1.0);
  GeneticTrustRegionParams p;
  const OptimizationResult outside = minimizeGeneticTrustRegion(twoWells(), omega, v2(0, 0), p);
  EXPECT_EQ(outside.outcome, OptimizationOutcome::kInvalidInput);
  EXPECT_NE(outside.message.find("not in the feasible set"), std::string::npos) << outside.message;
  const OptimizationResult nan = minimizeGeneticTrustRegion(twoWells(), {}, v2(std::nan(""), 0), p);
  EXPECT_EQ(nan.outcome, OptimizationOutcome::kInvalidInput);
  p.eta1 = 0.8;  // eta1 >= eta2
  const OptimizationResult bad = minimizeGeneticTrustRegion(twoWells(), {}, v2(0, 0), p);
  EXPECT_EQ(bad.outcome, OptimizationOutcome::kInvalidInput);
  EXPECT_NE(bad.message.find("eta1"), std::string::npos) << bad.message;
}

TEST(GeneticTrustRegionParams, ValidateNamesTheSymbol) {
  auto fails = [](auto mutate, const char* symbol) {
    GeneticTrustRegionParams p;
    mutate(p);
    const Status s = p.validate();
    EXPECT_FALSE(s.ok()) << symbol;
    EXPECT_NE(s.message().find(symbol), std::string::npos) << s.message();
  };
  EXPECT_TRUE(GeneticTrustRegionParams{}.validate().ok());
  fails([](auto& p) { p.M = 1.0; }, "M");
  fails([](auto& p) { p.beta3 = 0.9; }, "beta3");
  fails([](auto& p) { p.beta1 = 0.6; }, "beta1");
  fails([](auto& p) { p.eta2 = 1.0; }, "eta2");
  fails([](auto& p) { p.delta0 = std::nan(""); }, "delta0");
  fails([](auto& p) { p.ga_elite = 40; }, "ga_elite");
}

}  // namespace
}  // namespace adit::fusion
