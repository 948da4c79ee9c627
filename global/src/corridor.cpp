// SPDX-License-Identifier: BSD-3-Clause
#include "corridor.hpp"

#include <algorithm>
#include <limits>

#include "geometry.hpp"

namespace adit::global {

using map::Vec3;

namespace {
// Douglas-Peucker on the axis; each kept segment takes the largest radius of what it replaces.
void simplify(const std::vector<Vec3>& pts, const std::vector<double>& radius, std::size_t lo, std::size_t hi,
              double tol, std::vector<std::size_t>* keep) {
  double worst = -1;
  std::size_t at = lo;
  for (std::size_t i = lo + 1; i < hi; ++i) {
    const double d = segmentDistance(pts[i], pts[lo], pts[hi]);
    if (d > worst) worst = d, at = i;
  }
  if (worst > tol) {
    simplify(pts, radius, lo, at, tol, keep);
    keep->push_back(at);
    simplify(pts, radius, at, hi, tol, keep);
  }
}
}  // namespace

Corridor::Corridor(const Route& route, double tolerance_m) {
  const std::vector<Vec3>& pts = route.axis.points;
  if (pts.size() == 1) {
    segments_.push_back({pts[0], pts[0], route.radius_m.empty() ? 1.0 : route.radius_m[0], {}});
  } else {
    std::vector<std::size_t> keep{0};
    simplify(pts, route.radius_m, 0, pts.size() - 1, tolerance_m, &keep);
    keep.push_back(pts.size() - 1);
    for (std::size_t k = 0; k + 1 < keep.size(); ++k) {
      double r = 0;
      for (std::size_t i = keep[k]; i < keep[k + 1]; ++i) r = std::max(r, route.radius_m[i]);
      segments_.push_back({pts[keep[k]], pts[keep[k + 1]], r + tolerance_m, {}});
    }
  }
  double total = 0;
  for (Segment& s : segments_) {
    s.box.extend(s.a);
    s.box.extend(s.b);
    s.box = s.box.inflated(s.radius);
    bounds_.extend(s.box);
    total += (s.b - s.a).norm() + s.radius;  // the radius term keeps short end pieces reachable
    cumulative_.push_back(total);
  }
}

Corridor::Corridor(const map::Aabb& box) : bounds_(box), box_(true) {}

bool Corridor::contains(const Vec3& p) const {
  if (box_) return bounds_.contains(p);
  for (const Segment& s : segments_)
    if (s.box.contains(p) && segmentDistance(p, s.a, s.b) <= s.radius) return true;
  return false;
}

Vec3 Corridor::sample(std::mt19937_64& rng, Vec3* axis_point) const {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  if (box_) {
    const Vec3 p = bounds_.min + (bounds_.max - bounds_.min).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    if (axis_point) *axis_point = Vec3(p.x(), p.y(), bounds_.max.z());
    return p;
  }
  const double pick = u(rng) * cumulative_.back();
  const std::size_t i = std::size_t(std::upper_bound(cumulative_.begin(), cumulative_.end(), pick) - cumulative_.begin());
  const Segment& s = segments_[std::min(i, segments_.size() - 1)];
  const Vec3 c = s.a + u(rng) * (s.b - s.a);
  if (axis_point) *axis_point = c;
  Vec3 d;
  do {
    d = Vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
  } while (d.squaredNorm() > 1.0);
  return c + s.radius * d;
}

Vec3 Corridor::nearestAxisPoint(const Vec3& p) const {
  if (box_) return p;
  double best = std::numeric_limits<double>::infinity();
  Vec3 out = p;
  for (const Segment& s : segments_) {
    const Vec3 q = s.a + segmentParameter(p, s.a, s.b) * (s.b - s.a);
    const double d = (q - p).squaredNorm();
    if (d < best) best = d, out = q;
  }
  return out;
}

}  // namespace adit::global
