// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/genetic_trust_region.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

namespace adit::fusion {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool finite(const VectorX& v) { return v.array().isFinite().all(); }

/// Counts evaluations and turns NaN into +inf, so that a bad trial point is simply a bad point.
class CountedObjective {
 public:
  CountedObjective(const Objective& f, double fd_step) : f_(f), fd_step_(fd_step) {}

  double value(const VectorX& z) {
    ++evaluations;
    const double v = f_.value(z);
    return std::isnan(v) ? kInf : v;
  }
  VectorX gradient(const VectorX& z) {
    if (f_.gradient) return f_.gradient(z);
    VectorX g(z.size());
    VectorX p = z;
    for (Eigen::Index i = 0; i < z.size(); ++i) {
      const double h = fd_step_ * std::max(1.0, std::abs(z[i]));
      p[i] = z[i] + h;
      const double up = value(p);
      p[i] = z[i] - h;
      const double down = value(p);
      p[i] = z[i];
      g[i] = (up - down) / (2 * h);
    }
    return g;
  }

  int evaluations = 0;

 private:
  const Objective& f_;
  double fd_step_;
};

/// The dogleg step of the model g^T d + ½ d^T B d within |d| ≤ Δ (B symmetric positive definite).
VectorX doglegStep(const VectorX& g, const Eigen::MatrixXd& B, double delta) {
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(B);
  const VectorX pb = -ldlt.solve(g);
  if (finite(pb) && pb.norm() <= delta) return pb;
  const double gBg = g.dot(B * g);
  const double gnorm = g.norm();
  if (!(gBg > 0) || !finite(pb)) return -delta / gnorm * g;
  const VectorX pu = -(g.dot(g) / gBg) * g;
  if (pu.norm() >= delta) return -delta / gnorm * g;
  // |pu + tau (pb - pu)| = delta, tau in [0, 1]
  const VectorX diff = pb - pu;
  const double a = diff.squaredNorm(), b = 2 * pu.dot(diff), c = pu.squaredNorm() - delta * delta;
  const double tau = (-b + std::sqrt(std::max(0.0, b * b - 4 * a * c))) / (2 * a);
  return pu + std::clamp(tau, 0.0, 1.0) * diff;
}

/// Largest α in [0, 1] (to bisection precision) with z + α d in Ω; z itself is in Ω.
double feasibleFraction(const FeasibleSet& omega, const VectorX& z, const VectorX& d) {
  if (omega.holds(z + d)) return 1.0;
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (omega.holds(z + mid * d) ? lo : hi) = mid;
  }
  return lo;
}

std::string formatVector(const VectorX& z) {
  std::ostringstream os;
  os << "(";
  for (Eigen::Index i = 0; i < z.size(); ++i) os << (i ? ", " : "") << z[i];
  os << ")";
  return os.str();
}

}  // namespace

FeasibleSet FeasibleSet::annulus(const VectorX& centre, double r_inner, double r_outer) {
  FeasibleSet s;
  s.contains = [centre, r_inner, r_outer](const VectorX& z) {
    const double r = (z - centre).norm();
    return r >= r_inner && r <= r_outer;
  };
  s.project = [centre, r_inner, r_outer](const VectorX& z) {
    const VectorX v = z - centre;
    const double r = v.norm();
    if (!(r > 1e-12)) {
      VectorX e = VectorX::Zero(centre.size());
      e[0] = 1.0;
      return VectorX(centre + r_inner * e);
    }
    return VectorX(centre + std::clamp(r, r_inner, r_outer) / r * v);
  };
  std::ostringstream os;
  os << "annulus R in [" << r_inner << ", " << r_outer << "] around " << formatVector(centre);
  s.name = os.str();
  return s;
}

Status GeneticTrustRegionParams::validate() const {
  auto bad = [](const char* symbol, double v, const char* rule) {
    std::ostringstream os;
    os << "genetic trust region: " << symbol << " = " << v << " violates " << rule;
    return invalidArgument(os.str());
  };
  for (const auto& [name, v] :
       {std::pair<const char*, double>{"delta0", delta0}, {"delta_max", delta_max}, {"eta1", eta1}, {"eta2", eta2},
        {"beta1", beta1}, {"beta2", beta2}, {"beta3", beta3}, {"eps1", eps1}, {"eps2", eps2}, {"eps3", eps3},
        {"M", M}, {"fd_step", fd_step}, {"ga_radius", ga_radius}, {"ga_crossover", ga_crossover},
        {"ga_mutation", ga_mutation}, {"ga_sigma", ga_sigma}})
    if (!std::isfinite(v)) return bad(name, v, "finite");
  if (!(delta0 > 0)) return bad("delta0", delta0, "delta0 > 0");
  if (!(delta_max >= delta0)) return bad("delta_max", delta_max, "delta_max >= delta0");
  if (!(eta1 > 0 && eta1 < eta2)) return bad("eta1", eta1, "0 < eta1 < eta2");
  if (!(eta2 < 1)) return bad("eta2", eta2, "eta2 < 1");
  if (!(beta1 > 0 && beta1 <= beta2)) return bad("beta1", beta1, "0 < beta1 <= beta2");
  if (!(beta2 < 1)) return bad("beta2", beta2, "beta2 < 1");
  if (!(beta3 >= 1)) return bad("beta3", beta3, "beta3 >= 1");
  if (!(eps1 > 0)) return bad("eps1", eps1, "eps1 > 0");
  if (!(eps2 > 0)) return bad("eps2", eps2, "eps2 > 0");
  if (!(eps3 > 0)) return bad("eps3", eps3, "eps3 > 0");
  if (!(M > 1)) return bad("M", M, "M > 1");
  if (max_iterations < 1) return bad("max_iterations", max_iterations, "max_iterations >= 1");
  if (max_restarts < 0) return bad("max_restarts", max_restarts, "max_restarts >= 0");
  if (!(fd_step > 0)) return bad("fd_step", fd_step, "fd_step > 0");
  if (!(ga_radius > 0)) return bad("ga_radius", ga_radius, "ga_radius > 0");
  if (ga_population < 4) return bad("ga_population", ga_population, "ga_population >= 4");
  if (ga_generations < 1) return bad("ga_generations", ga_generations, "ga_generations >= 1");
  if (!(ga_crossover >= 0 && ga_crossover <= 1)) return bad("ga_crossover", ga_crossover, "0 <= ga_crossover <= 1");
  if (!(ga_mutation >= 0 && ga_mutation <= 1)) return bad("ga_mutation", ga_mutation, "0 <= ga_mutation <= 1");
  if (!(ga_sigma > 0)) return bad("ga_sigma", ga_sigma, "ga_sigma > 0");
  if (ga_elite < 0 || ga_elite >= ga_population) return bad("ga_elite", ga_elite, "0 <= ga_elite < ga_population");
  if (ga_tournament < 1 || ga_tournament > ga_population)
    return bad("ga_tournament", ga_tournament, "1 <= ga_tournament <= ga_population");
  return {};
}

const char* optimizationOutcomeName(OptimizationOutcome o) {
  switch (o) {
    case OptimizationOutcome::kConverged: return "converged";
    case OptimizationOutcome::kStagnated: return "stagnated";
    case OptimizationOutcome::kMaxIterations: return "max_iterations";
    case OptimizationOutcome::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

VectorX geneticSearch(const std::function<double(const VectorX&)>& value, const FeasibleSet& omega,
                      const VectorX& centre, const GeneticTrustRegionParams& p, std::uint64_t seed,
                      int* evaluations) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Index n = centre.size();
  auto eval = [&](const VectorX& z) {
    if (evaluations) ++*evaluations;
    const double v = value(z);
    return std::isnan(v) ? kInf : v;
  };
  // Keeps a candidate in the neighbourhood and in Ω; false when it cannot be repaired.
  auto admit = [&](VectorX& z) {
    const VectorX off = z - centre;
    if (off.norm() > p.ga_radius) z = centre + p.ga_radius / off.norm() * off;
    if (omega.holds(z)) return true;
    if (!omega.project) return false;
    z = omega.project(z);
    return finite(z) && omega.holds(z) && (z - centre).norm() <= p.ga_radius * (1 + 1e-9);
  };
  auto randomInBall = [&]() {
    VectorX dir(n);
    for (Eigen::Index i = 0; i < n; ++i) dir[i] = normal(rng);
    const double len = dir.norm();
    if (!(len > 0)) return centre;
    return VectorX(centre + p.ga_radius * std::pow(uni(rng), 1.0 / double(n)) / len * dir);
  };

  struct Individual {
    VectorX z;
    double fitness;
  };
  std::vector<Individual> pop;
  pop.reserve(p.ga_population);
  pop.push_back({centre, eval(centre)});
  while (static_cast<int>(pop.size()) < p.ga_population) {
    VectorX z = randomInBall();
    for (int tries = 0; tries < 20 && !admit(z); ++tries) z = randomInBall();
    if (!omega.holds(z)) z = centre;
    pop.push_back({z, eval(z)});
  }
  auto better = [](const Individual& a, const Individual& b) { return a.fitness < b.fitness; };
  auto tournament = [&]() -> const Individual& {
    const Individual* best = nullptr;
    for (int t = 0; t < p.ga_tournament; ++t) {
      const Individual& c = pop[static_cast<std::size_t>(uni(rng) * pop.size()) % pop.size()];
      if (!best || c.fitness < best->fitness) best = &c;
    }
    return *best;
  };
  for (int gen = 0; gen < p.ga_generations; ++gen) {
    std::stable_sort(pop.begin(), pop.end(), better);
    std::vector<Individual> next(pop.begin(), pop.begin() + p.ga_elite);
    while (static_cast<int>(next.size()) < p.ga_population) {
      const Individual& a = tournament();
      const Individual& b = tournament();
      VectorX child = a.z;
      if (uni(rng) < p.ga_crossover) {  // blend crossover (BLX-0.5)
        for (Eigen::Index i = 0; i < n; ++i) {
          const double lo = std::min(a.z[i], b.z[i]), hi = std::max(a.z[i], b.z[i]), span = hi - lo;
          child[i] = lo - 0.5 * span + uni(rng) * 2.0 * span;
        }
      }
      if (uni(rng) < p.ga_mutation)
        for (Eigen::Index i = 0; i < n; ++i) child[i] += p.ga_sigma * p.ga_radius * normal(rng);
      if (!admit(child)) child = a.z;
      next.push_back({child, eval(child)});
    }
    pop = std::move(next);
  }
  return std::min_element(pop.begin(), pop.end(), better)->z;
}

OptimizationResult minimizeGeneticTrustRegion(const Objective& f, const FeasibleSet& omega, const VectorX& z0,
                                              const GeneticTrustRegionParams& p,
                                              const std::function<void(const IterationRecord&)>& on_iteration) {
  OptimizationResult res;
  res.z = z0;
  auto fail = [&](const std::string& why) {
    res.outcome = OptimizationOutcome::kInvalidInput;
    res.message = why;
    return res;
  };
  if (const Status s = p.validate(); !s.ok()) return fail(s.message());
  if (!f.value) return fail("genetic trust region: no objective");
  if (z0.size() == 0 || !finite(z0)) return fail("genetic trust region: start " + formatVector(z0) + " is not finite");
  if (!omega.holds(z0))
    return fail("genetic trust region: start " + formatVector(z0) + " is not in the feasible set (" + omega.name + ")");

  CountedObjective U(f, p.fd_step);
  const Eigen::Index n = z0.size();
  VectorX z = z0;
  double u = U.value(z);
  if (!std::isfinite(u)) return fail("genetic trust region: U at the start " + formatVector(z0) + " is not finite");
  VectorX g = U.gradient(z);
  if (!finite(g)) return fail("genetic trust region: the gradient at the start is not finite");
  Eigen::MatrixXd B = Eigen::MatrixXd::Identity(n, n);  // step 1: B0 = I
  double delta = p.delta0;
  double last_gain = 0.0;  // |U_{k+1} - U_k| of the last trust-region iteration

  auto record = [&](IterationRecord r) {
    if (on_iteration) on_iteration(r);
    res.log.push_back(std::move(r));
  };
  auto finish = [&](OptimizationOutcome o, std::string message) {
    res.outcome = o;
    res.message = std::move(message);
    res.z = z;
    res.value = u;
    res.grad_norm = g.norm();
    res.evaluations = U.evaluations;
    return res;
  };
  // Steps 6-7: true when the genetic search's point passed the M test and the method restarts.
  auto geneticRestart = [&](int k) {
    if (res.restarts >= p.max_restarts) return false;
    int evals = 0;
    const VectorX zc = geneticSearch([&](const VectorX& x) { return U.value(x); }, omega, z, p,
                                     p.seed + 7919u * static_cast<std::uint64_t>(k + 1), &evals);
    const double uc = U.value(zc);
    IterationRecord r;
    r.k = k;
    r.ratio = kNaN;
    r.grad_norm = g.norm();
    r.step_norm = (zc - z).norm();
    if (u - uc > p.M * std::max(last_gain, p.eps3)) {
      z = zc;
      u = uc;
      const double gk = g.norm();
      g = U.gradient(z);
      B.setIdentity();
      delta = std::min(p.delta_max, std::max(p.delta0, gk));
      ++res.restarts;
      r.event = IterationRecord::Event::kGeneticJump;
      r.accepted = true;
    } else {
      r.event = IterationRecord::Event::kGeneticRejected;
    }
    r.z = z;
    r.value = u;
    r.delta = delta;
    record(r);
    return r.accepted;
  };

  for (int k = 0; k < p.max_iterations; ++k) {
    res.iterations = k + 1;
    // Step 2.
    if (g.norm() < p.eps1) {
      if (p.ga_at_stationary && geneticRestart(k)) continue;
      return finish(OptimizationOutcome::kConverged, "|g| < eps1 at " + formatVector(z));
    }
    // Step 3: the model's step, cut back to Ω.
    VectorX d = doglegStep(g, B, delta);
    const bool full_length = d.norm() >= delta * (1 - 1e-9);
    auto model = [&](const VectorX& step) { return g.dot(step) + 0.5 * step.dot(B * step); };  // m_k(d) - m_k(0)
    if (!omega.holds(z + d)) {
      // z_k + d_k must stay in Ω (eq. 14): the step cut back to Ω's boundary, or, when Ω can
      // project, the projected point if it is inside the trust region and the model prefers it
      // (that lets the iterate slide along a boundary instead of stalling on it).
      const VectorX full = d;
      const VectorX cut = feasibleFraction(omega, z, full) * full;
      d = cut;
      if (omega.project) {
        const VectorX proj = omega.project(z + full) - z;
        if (finite(proj) && proj.norm() <= delta * (1 + 1e-9) && omega.holds(z + proj) && model(proj) < model(cut))
          d = proj;
      }
    }
    const double predicted = model(d);
    // Step 4: ratio test (eq. 15) and acceptance (eq. 16).
    const VectorX trial = z + d;
    const double u_trial = d.norm() > 0 ? U.value(trial) : u;
    const double ratio = predicted < 0 ? (u_trial - u) / predicted : -kInf;
    const bool accept = ratio > p.eta1 && omega.holds(trial);
    // Step 5: the radius bands (eq. 17).
    if (ratio > p.eta2)
      delta = full_length ? std::min(p.delta_max, p.beta3 * delta) : delta;
    else if (ratio < p.eta1)
      delta = p.beta1 * delta;
    // (eta1 <= ratio <= eta2: the top of [beta2 delta, delta], i.e. unchanged)
    const double u_before = u;
    if (accept) {
      const VectorX g_new = U.gradient(trial);
      // Step 8: BFGS, skipped when the curvature condition fails so that B stays positive definite.
      const VectorX y = g_new - g;
      const double ys = y.dot(d);
      if (ys > 1e-12 * y.norm() * d.norm()) {
        const VectorX Bs = B * d;
        B += y * y.transpose() / ys - Bs * Bs.transpose() / d.dot(Bs);
      }
      z = trial;
      u = u_trial;
      g = g_new;
    }
    last_gain = std::abs(u - u_before);
    IterationRecord r;
    r.k = k;
    r.z = z;
    r.value = u;
    r.grad_norm = g.norm();
    r.delta = delta;
    r.ratio = ratio;
    r.step_norm = d.norm();
    r.accepted = accept;
    record(r);
    // Step 6: stagnation.
    if (delta < p.eps2 && last_gain < p.eps3) {
      if (geneticRestart(k)) continue;
      return finish(OptimizationOutcome::kStagnated,
                    "the trust region stagnated at " + formatVector(z) + " (radius " + std::to_string(delta) +
                        ") and the genetic search found no better point: a constrained or confirmed minimum");
    }
  }
  return finish(OptimizationOutcome::kMaxIterations,
                "stopped after " + std::to_string(p.max_iterations) + " iterations at " + formatVector(z));
}

}  // namespace adit::fusion
