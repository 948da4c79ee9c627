// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The genetic trust-region method of Tian, Gao & Zhang 2016 (§2.3, eqs. 14–17), as
/// written: a trust-region model with a BFGS Hessian, the
/// ratio test and the radius bands, and — when the trust region stagnates — a genetic search in a
/// neighbourhood of the iterate whose better point restarts the trust region. The paper uses it to
/// place sub-goals in an annulus around the robot and the break points of the expected path; here
/// it is a general minimiser over R^n with an explicit feasible set Ω, so both uses (and the tests
/// on analytic functions) call the same code.
///
///   GeneticTrustRegionParams p;            // the paper's symbols, validated
///   Objective f{[](const Eigen::VectorXd& z) { return rosenbrock(z); }};   // numerical gradient
///   FeasibleSet omega = FeasibleSet::annulus(centre, r_inner, r_outer);
///   OptimizationResult r = minimizeGeneticTrustRegion(f, omega, z0, p);
///   if (r.outcome == OptimizationOutcome::kConverged) use(r.z);
///
/// The steps (numbers as in the paper):
///  1. Δ = Δ0, B = I.   2. stop when |g_k| < ε1.
///  3. trial step d_k: argmin g^T d + ½ d^T B d over |d| ≤ Δ (dogleg on the BFGS model, which
///     stays positive definite because updates that would break it are skipped); if z_k + d_k
///     leaves Ω the step is cut back along d to Ω's boundary (bisection on the membership test),
///     so Ω is honoured explicitly, never by a penalty.
///  4. r_k = (U(z_k + d_k) − U(z_k)) / (m_k(d_k) − m_k(0)) (eq. 15); accept when r_k > η1 and
///     z_k + d_k ∈ Ω (eq. 16).
///  5. radius bands (eq. 17): r_k > η2 → Δ ∈ [Δ, β3Δ] (β3Δ when the step reached the boundary,
///     else Δ); η1 ≤ r_k ≤ η2 → Δ (the top of [β2Δ, Δ]); r_k < η1 → β1Δ ... β2Δ (β1Δ).
///  6. stagnation, Δ < ε2 and |U_{k+1} − U_k| < ε3: a genetic search in the ball of radius
///     `ga_radius` around z_{k+1} (restricted to Ω) for z^c.
///  7. the M test. **Interpretation** (the OCR's "|U_{k+1} − U^c| > M |U_{k+1} − U^e|" names a
///     U^e it never defines): z^c replaces the iterate when it is better by more than M times the
///     last trust-region gain, U_{k+1} − U^c > M·max(|U_{k+1} − U_k|, ε3); then B = I,
///     Δ = max(Δ0, |g_k|) and the method restarts at step 1. Otherwise the trust region has
///     converged to a (constrained) minimum that the genetic search cannot improve: stop.
///  8. BFGS update of B, k = k + 1.
/// A stationary point stops the paper's method at step 2, before any genetic search; the option
/// `ga_at_stationary` (off by default, the paper's behaviour) runs the step-6/7 search there too,
/// for multi-modal objectives.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "adit/status.hpp"

namespace adit::fusion {

using VectorX = Eigen::VectorXd;

/// The objective U. Without a gradient, central differences of step `fd_step` are used.
struct Objective {
  std::function<double(const VectorX&)> value;
  std::function<VectorX(const VectorX&)> gradient;  ///< optional
};

/// Ω, the feasible set. Empty `contains` means R^n. `project`, when given, maps any point to a
/// nearby point of Ω; the genetic search then repairs infeasible children instead of discarding
/// them (rejection starves in thin sets such as a narrow annulus).
struct FeasibleSet {
  std::function<bool(const VectorX&)> contains;
  std::function<VectorX(const VectorX&)> project;
  std::string name = "R^n";

  bool holds(const VectorX& z) const { return !contains || contains(z); }
  /// The paper's sub-goal set: R ∈ [r_inner, r_outer] around `centre` (2-D or 3-D).
  static FeasibleSet annulus(const VectorX& centre, double r_inner, double r_outer);
};

struct GeneticTrustRegionParams {
  // Trust region (eqs. 14–17); the paper requires 0 < η1 < η2 < 1, 0 < β1 ≤ β2 < 1 ≤ β3, M > 1.
  double delta0 = 0.5;      ///< Δ0, initial radius (and the floor of the radius after a restart)
  double delta_max = 50.0;  ///< cap on Δ
  double eta1 = 0.1;        ///< η1, acceptance threshold of r_k
  double eta2 = 0.75;       ///< η2, "very successful" threshold
  double beta1 = 0.25;      ///< β1, lower shrink factor
  double beta2 = 0.5;       ///< β2, upper shrink factor
  double beta3 = 2.0;       ///< β3, growth factor
  double eps1 = 1e-6;       ///< ε1, stop when |g| < ε1
  double eps2 = 1e-4;       ///< ε2, stagnation radius
  double eps3 = 1e-10;      ///< ε3, stagnation change of U
  double M = 2.0;           ///< M > 1, the genetic jump's margin over the trust region's last gain
  int max_iterations = 500;
  int max_restarts = 20;
  double fd_step = 1e-6;    ///< central-difference step when no gradient is given
  bool ga_at_stationary = false;  ///< also search genetically at |g| < ε1 (not in the paper)

  // Genetic search (step 6): real-coded, tournament selection, blend crossover, Gaussian mutation,
  // elitism; deterministic for a given seed.
  double ga_radius = 2.0;     ///< neighbourhood radius around the iterate
  int ga_population = 40;
  int ga_generations = 40;
  double ga_crossover = 0.9;  ///< probability of crossover per child
  double ga_mutation = 0.2;   ///< probability of mutating a child
  double ga_sigma = 0.15;     ///< mutation standard deviation, as a fraction of ga_radius
  int ga_elite = 2;
  int ga_tournament = 3;
  std::uint64_t seed = 1;

  /// OK, or the first symbol that breaks the paper's constraints, with its value.
  Status validate() const;
};

enum class OptimizationOutcome {
  kConverged,      ///< |g| < ε1
  kStagnated,      ///< Δ < ε2, U no longer changes and the genetic search found nothing better:
                   ///< a constrained minimum (e.g. on Ω's boundary) or a minimum the search confirms
  kMaxIterations,
  kInvalidInput,   ///< z0 not finite, not in Ω, U(z0) not finite, or invalid parameters
};
const char* optimizationOutcomeName(OptimizationOutcome o);

/// One line of the iteration log (the paper's quantities at iteration k).
struct IterationRecord {
  enum class Event { kStep, kGeneticJump, kGeneticRejected };
  int k = 0;
  Event event = Event::kStep;
  VectorX z;              ///< iterate after the iteration
  double value = 0.0;     ///< U(z)
  double grad_norm = 0.0; ///< |g_k| at the iterate before the step
  double delta = 0.0;     ///< Δ after the radius update
  double ratio = 0.0;     ///< r_k (eq. 15); NaN for genetic events
  double step_norm = 0.0; ///< |d_k| (after cutting back to Ω)
  bool accepted = false;
};

struct OptimizationResult {
  OptimizationOutcome outcome = OptimizationOutcome::kInvalidInput;
  std::string message;
  VectorX z;
  double value = 0.0;
  double grad_norm = 0.0;
  int iterations = 0;
  int restarts = 0;      ///< accepted genetic jumps
  int evaluations = 0;   ///< calls of U (gradients by differences included)
  std::vector<IterationRecord> log;
};

/// Minimises `f` over Ω from `z0`. Never throws; a NaN objective value at a trial point counts as
/// a failed step (r_k = −∞). `on_iteration`, when given, sees every record as it is made.
OptimizationResult minimizeGeneticTrustRegion(const Objective& f, const FeasibleSet& omega, const VectorX& z0,
                                              const GeneticTrustRegionParams& params,
                                              const std::function<void(const IterationRecord&)>& on_iteration = {});

/// The step-6 genetic search alone: the best point found in Ω ∩ ball(centre, params.ga_radius),
/// never worse than `centre` itself (which seeds the population). `evaluations` is incremented.
VectorX geneticSearch(const std::function<double(const VectorX&)>& value, const FeasibleSet& omega,
                      const VectorX& centre, const GeneticTrustRegionParams& params, std::uint64_t seed,
                      int* evaluations = nullptr);

}  // namespace adit::fusion
