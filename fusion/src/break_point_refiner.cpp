// SPDX-License-Identifier: BSD-3-Clause
#include "adit/fusion/break_point_refiner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace adit::fusion {

using map::Polyline;
using map::Vec3;

ClearanceFn fieldClearance(const map::DistanceField& field, double robot_radius_m) {
  return [&field, robot_radius_m](const Vec3& p) { return field.distance(p) - robot_radius_m; };
}

GeneticTrustRegionParams BreakPointRefinerParams::defaultOptimizer() {
  GeneticTrustRegionParams p;
  p.delta0 = 0.5;
  p.eps1 = 1e-4;
  p.eps2 = 1e-3;
  p.eps3 = 1e-7;
  p.max_iterations = 300;
  p.max_restarts = 5;
  p.ga_radius = 0.5;
  p.ga_population = 24;
  p.ga_generations = 15;
  return p;
}

BreakPointRefinerParams BreakPointRefinerParams::forField(double resolution_m, double safety_margin_m) {
  BreakPointRefinerParams p;
  p.sample_step_m = resolution_m;
  p.min_clearance_m = safety_margin_m + 0.5 * resolution_m;
  return p;
}

Status BreakPointRefinerParams::validate() const {
  auto bad = [](const char* field, double v, const char* rule) {
    std::ostringstream os;
    os << "break point refiner: " << field << " = " << v << " must be " << rule;
    return invalidArgument(os.str());
  };
  if (!(clearance_weight >= 0) || !std::isfinite(clearance_weight)) return bad("clearance_weight", clearance_weight, ">= 0");
  if (!(rho0_m > 0) || !std::isfinite(rho0_m)) return bad("rho0_m", rho0_m, "> 0");
  if (!std::isfinite(min_clearance_m)) return bad("min_clearance_m", min_clearance_m, "finite");
  if (!std::isfinite(clearance_slack_m)) return bad("clearance_slack_m", clearance_slack_m, "finite");
  if (!(sample_step_m > 0) || !std::isfinite(sample_step_m)) return bad("sample_step_m", sample_step_m, "> 0");
  if (!(move_radius_m > 0) || !std::isfinite(move_radius_m)) return bad("move_radius_m", move_radius_m, "> 0");
  return optimizer.validate();
}

const char* refineOutcomeName(RefineOutcome o) {
  switch (o) {
    case RefineOutcome::kRefined: return "refined";
    case RefineOutcome::kKeptInput: return "kept_input";
    case RefineOutcome::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

namespace {

int samplesFor(double length, double step) { return std::max(1, int(std::ceil(length / step))); }

std::string fmt(const Vec3& p) {
  std::ostringstream os;
  os.precision(3);
  os << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return os.str();
}

// Every sample of a-b (at most `step` apart, both ends included) has clearance >= `need`; else
// `why` names the first offending sample.
// With slack >= 0 (see BreakPointRefinerParams::clearance_slack_m) the samples that a clear one
// proves clear are skipped: the same answer and the same first offending sample.
bool segmentClear(const ClearanceFn& clearance, const Vec3& a, const Vec3& b, double step, double need,
                  std::string* why = nullptr, double slack = -1.0) {
  if (!map::allFinite(a) || !map::allFinite(b)) {
    if (why) *why = "a vertex is not finite";
    return false;
  }
  const double len = (b - a).norm();
  const int n = samplesFor(len, step);
  const double spacing = len / n;
  for (int k = 0; k <= n; ++k) {
    const Vec3 q = a + (b - a) * (double(k) / n);
    const double c = clearance(q);
    if (c >= need && slack >= 0.0 && spacing > 0.0) {
      // Samples within c - need - slack of q are clear (1e-9: rounding of the sample spacing).
      const double proven = c - need - slack - 1e-9;
      if (proven >= spacing) k += int(std::min(double(n), std::floor(proven / spacing)));
      continue;
    }
    if (!(c >= need)) {
      if (why) {
        std::ostringstream os;
        os << "clearance " << c << " m at " << fmt(q) << ", below the required " << need << " m";
        *why = os.str();
      }
      return false;
    }
  }
  return true;
}

// The decision vector and the objective. Each segment keeps the sample count fixed at what its
// longest possible length needs, so the objective is continuous in z.
class PathModel {
 public:
  PathModel(const Polyline& input, const ClearanceFn& clearance, const BreakPointRefinerParams& p,
            const VertexPlacement& place)
      : input_(input.points), clearance_(clearance), p_(p), place_(p.planar ? place : VertexPlacement()),
        dim_(p.planar ? 2 : 3) {
    for (std::size_t i = 0; i + 1 < input_.size(); ++i)
      samples_.push_back(samplesFor((input_[i + 1] - input_[i]).norm() + 2 * p.move_radius_m, p.sample_step_m));
  }

  std::size_t interior() const { return input_.size() - 2; }
  int dimension() const { return int(interior()) * dim_; }

  VectorX initial() const {
    VectorX z(dimension());
    for (std::size_t j = 0; j < interior(); ++j) z.segment(int(j) * dim_, dim_) = input_[j + 1].head(dim_);
    return z;
  }
  std::vector<Vec3> points(const VectorX& z) const {
    std::vector<Vec3> pts = input_;
    for (std::size_t j = 0; j < interior(); ++j) {
      pts[j + 1].head(dim_) = z.segment(int(j) * dim_, dim_);
      // A vertex that has not moved keeps its height: the input stays the input exactly.
      if (place_ && pts[j + 1] != input_[j + 1]) pts[j + 1] = place_(pts[j + 1]);
    }
    return pts;
  }

  double penalty(double c) const {
    if (c >= p_.rho0_m) return 0.0;
    const double d = 1.0 / std::max(c, 1e-3) - 1.0 / p_.rho0_m;
    return 0.5 * d * d;
  }
  double segmentCost(const Vec3& a, const Vec3& b, std::size_t seg) const {
    const double len = (b - a).norm();
    if (p_.clearance_weight == 0) return len;
    return memo(costs_, SegmentKey(a, b, seg), [&] {
      const int n = samples_[seg];
      double sum = 0;
      for (int k = 0; k < n; ++k) sum += penalty(clearance_(a + (b - a) * ((k + 0.5) / n)));
      return len + p_.clearance_weight * sum * len / n;
    });
  }
  double value(const VectorX& z) const { return valueOf(points(z)); }
  double valueOf(const std::vector<Vec3>& pts) const {
    double u = 0;
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) u += segmentCost(pts[i], pts[i + 1], i);
    return u;
  }
  // Central differences, but a coordinate of vertex j only changes segments j-1 and j: two
  // segments per evaluation instead of the whole path.
  VectorX gradient(const VectorX& z) const {
    std::vector<Vec3> pts = points(z);
    VectorX g(dimension());
    const double h = 1e-4;
    for (std::size_t j = 0; j < interior(); ++j) {
      const std::size_t v = j + 1;
      for (int c = 0; c < dim_; ++c) {
        const double keep = pts[v][c];
        pts[v][c] = keep + h;
        const double up = segmentCost(pts[v - 1], pts[v], v - 1) + segmentCost(pts[v], pts[v + 1], v);
        pts[v][c] = keep - h;
        const double down = segmentCost(pts[v - 1], pts[v], v - 1) + segmentCost(pts[v], pts[v + 1], v);
        pts[v][c] = keep;
        g[int(j) * dim_ + c] = (up - down) / (2 * h);
      }
    }
    return g;
  }

  bool withinMoveRadius(const VectorX& z) const {
    for (std::size_t j = 0; j < interior(); ++j)
      if ((z.segment(int(j) * dim_, dim_) - input_[j + 1].head(dim_)).norm() > p_.move_radius_m) return false;
    return true;
  }
  VectorX clampToMoveRadius(const VectorX& z) const {
    VectorX out = z;
    for (std::size_t j = 0; j < interior(); ++j) {
      const VectorX c = input_[j + 1].head(dim_);
      const VectorX d = z.segment(int(j) * dim_, dim_) - c;
      const double r = d.norm();
      if (r > p_.move_radius_m) out.segment(int(j) * dim_, dim_) = c + d * (p_.move_radius_m / r);
    }
    return out;
  }
  bool feasible(const VectorX& z) const {
    if (!z.allFinite() || !withinMoveRadius(z)) return false;
    const std::vector<Vec3> pts = points(z);
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      const bool clear = memo(clear_, SegmentKey(pts[i], pts[i + 1], i), [&] {
        return segmentClear(clearance_, pts[i], pts[i + 1], p_.sample_step_m, p_.min_clearance_m, nullptr,
                            p_.clearance_slack_m);
      });
      if (!clear) return false;
    }
    return true;
  }

 private:
  // The search comes back to the same segments (a vertex it left where it was, the value after
  // a gradient, a candidate checked and then scored): a third of the objective's segments in a
  // district campaign. Each segment's cost and clearance, by its two ends' bits, kept for this
  // refinement (both are functions of the ends alone; at most kMemo of each, then started over).
  struct SegmentKey {
    std::uint64_t bits[6];
    std::size_t seg;
    SegmentKey(const Vec3& a, const Vec3& b, std::size_t s) : seg(s) {
      for (int c = 0; c < 3; ++c) {
        std::memcpy(&bits[c], &a[c], sizeof(double));
        std::memcpy(&bits[3 + c], &b[c], sizeof(double));
      }
    }
    bool operator==(const SegmentKey& o) const {
      return seg == o.seg && std::equal(std::begin(bits), std::end(bits), std::begin(o.bits));
    }
  };
  struct SegmentKeyHash {
    std::size_t operator()(const SegmentKey& k) const {
      std::uint64_t h = 0x9E3779B97F4A7C15ull ^ k.seg;
      for (std::uint64_t b : k.bits) h = (h ^ b) * 0x100000001B3ull, h ^= h >> 29;
      return std::size_t(h);
    }
  };
  static constexpr std::size_t kMemo = 1u << 16;
  // The value kept for `k`, else compute() kept.
  template <class Map, class Compute>
  static typename Map::mapped_type memo(Map& m, const SegmentKey& k, Compute compute) {
    if (const auto it = m.find(k); it != m.end()) return it->second;
    const typename Map::mapped_type v = compute();
    if (m.size() >= kMemo) m.clear();
    m.emplace(k, v);
    return v;
  }
  mutable std::unordered_map<SegmentKey, double, SegmentKeyHash> costs_;
  mutable std::unordered_map<SegmentKey, bool, SegmentKeyHash> clear_;

  std::vector<Vec3> input_;
  const ClearanceFn& clearance_;
  const BreakPointRefinerParams& p_;
  VertexPlacement place_;
  int dim_;
  std::vector<int> samples_;
};

}  // namespace

PathQuality measurePath(const Polyline& path, const ClearanceFn& clearance, double sample_step_m) {
  PathQuality q;
  q.length_m = path.length();
  q.break_points = path.size() >= 2 ? path.size() - 2 : 0;
  const std::vector<Vec3>& p = path.points;
  double sum = 0, lowest = std::numeric_limits<double>::infinity();
  std::size_t count = 0;
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const int n = samplesFor((p[i + 1] - p[i]).norm(), sample_step_m);
    for (int k = 0; k < n + (i + 2 == p.size() ? 1 : 0); ++k) {
      const double c = clearance(p[i] + (p[i + 1] - p[i]) * (double(k) / n));
      sum += c;
      lowest = std::min(lowest, c);
      ++count;
    }
  }
  q.min_clearance_m = count ? lowest : 0.0;
  q.mean_clearance_m = count ? sum / double(count) : 0.0;
  return q;
}

BreakPointRefinement refineBreakPoints(const Polyline& path, const ClearanceFn& clearance,
                                       const BreakPointRefinerParams& params, const SegmentCheck& extra_check,
                                       const VertexPlacement& place) {
  BreakPointRefinement r;
  r.path = path;
  auto refuse = [&](const std::string& why) {
    r.outcome = RefineOutcome::kInvalidInput;
    r.message = "break point refiner: " + why;
    r.after = r.before;
    return r;
  };
  if (Status s = params.validate(); !s.ok()) return refuse(s.message());
  if (!clearance) return refuse("no clearance function");
  if (path.size() < 2) return refuse("the path needs at least two points, got " + std::to_string(path.size()));
  for (std::size_t i = 0; i < path.size(); ++i)
    if (!map::allFinite(path.points[i])) return refuse("point " + std::to_string(i) + " is not finite");
  r.before = measurePath(path, clearance, params.sample_step_m);
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    std::string why;
    if (!segmentClear(clearance, path.points[i], path.points[i + 1], params.sample_step_m, params.min_clearance_m, &why,
                      params.clearance_slack_m))
      return refuse("input segment " + std::to_string(i) + " " + fmt(path.points[i]) + "-" + fmt(path.points[i + 1]) +
                    " is not clear: " + why);
  }
  const PathModel model(path, clearance, params, place);
  r.objective_before = r.objective_after = model.value(model.initial());
  r.after = r.before;
  r.outcome = RefineOutcome::kKeptInput;
  if (path.size() < 3) {
    r.message = "no break points to refine";
    return r;
  }

  Objective f;
  f.value = [&model](const VectorX& z) { return model.value(z); };
  f.gradient = [&model](const VectorX& z) { return model.gradient(z); };
  FeasibleSet omega;
  omega.contains = [&model](const VectorX& z) { return model.feasible(z); };
  omega.project = [&model](const VectorX& z) { return model.clampToMoveRadius(z); };
  omega.name = "segments clear, vertices within the move radius";
  r.optimization = minimizeGeneticTrustRegion(f, omega, model.initial(), params.optimizer);
  const OptimizationResult& o = r.optimization;

  std::ostringstream why;
  if (o.outcome == OptimizationOutcome::kInvalidInput) {
    why << "optimiser refused: " << o.message;
  } else if (!(o.value < r.objective_before)) {
    why << "the optimiser found nothing better (" << optimizationOutcomeName(o.outcome) << ")";
  } else {
    // Never trust the optimiser's bookkeeping: every segment again, then the caller's check. The
    // ends of a segment that fails go back to where they were (the optimiser knows only the
    // clearance, the caller's check also ground contact and slope along a segment), and the
    // segments that changed are checked again, until all pass: at worst the input itself. What
    // is kept must still lower the objective.
    Polyline out{model.points(o.z)};
    const std::vector<Vec3>& in = path.points;
    std::vector<bool> checked(out.size() - 1, false);
    std::size_t restored = 0;
    std::string first_failure;
    for (bool again = true; again;) {
      again = false;
      std::vector<std::size_t> failed;
      for (std::size_t i = 0; i + 1 < out.size(); ++i) {
        if (checked[i]) continue;
        checked[i] = true;
        if (out.points[i] == in[i] && out.points[i + 1] == in[i + 1]) continue;  // the input's own
        std::string seg_why;
        if (!segmentClear(clearance, out.points[i], out.points[i + 1], params.sample_step_m, params.min_clearance_m,
                          &seg_why, params.clearance_slack_m))
          seg_why = "failed re-validation: " + seg_why;
        else if (extra_check)
          if (Status s = extra_check(out.points[i], out.points[i + 1]); !s.ok()) seg_why = "failed the caller's check: " + s.message();
        if (seg_why.empty()) continue;
        if (first_failure.empty()) first_failure = "refined segment " + std::to_string(i) + " " + seg_why;
        failed.push_back(i);
      }
      for (std::size_t i : failed)
        for (std::size_t v : {i, i + 1}) {
          if (v == 0 || v + 1 == out.size() || out.points[v] == in[v]) continue;
          out.points[v] = in[v];
          ++restored;
          again = true;
          checked[v - 1] = false;  // v is interior: both its segments exist
          checked[v] = false;
        }
    }
    const double value = model.valueOf(out.points);
    const bool ok = value < r.objective_before;
    if (!ok) why << first_failure << (restored ? " (and the rest alone is no better)" : "");
    if (ok) {
      r.outcome = RefineOutcome::kRefined;
      r.path = std::move(out);
      r.after = measurePath(r.path, clearance, params.sample_step_m);
      r.objective_after = value;
      std::ostringstream m;
      m.precision(2);
      m << std::fixed << "refined " << r.before.break_points << " break points: length " << r.before.length_m << " -> "
        << r.after.length_m << " m, min clearance " << r.before.min_clearance_m << " -> " << r.after.min_clearance_m
        << " m (" << optimizationOutcomeName(o.outcome) << ", " << o.iterations << " iterations";
      if (restored) m << "; " << restored << " kept where they were, " << first_failure;
      m << ")";
      r.message = m.str();
      return r;
    }
  }
  r.message = "kept the input path: " + why.str();
  return r;
}

}  // namespace adit::fusion
