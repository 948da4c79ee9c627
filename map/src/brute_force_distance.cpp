// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/brute_force_distance.hpp"

#include <cmath>
#include <limits>

namespace adit::map {

StatusOr<BruteForceDistance> BruteForceDistance::create(const OccupancyMap& map, int margin_voxels,
                                                        double max_voxels) {
  BruteForceDistance b;
  b.map_ = &map;
  b.res_ = map.resolution();
  const Aabb box = map.bounds().inflated(margin_voxels * b.res_);
  const Vec3 n = (box.size() / b.res_).array().round();
  if (n.prod() > max_voxels) return outOfRange("brute force oracle: map too large (" + std::to_string(n.prod()) + " voxels)");
  for (int k = 0; k < int(n.z()); ++k)
    for (int j = 0; j < int(n.y()); ++j)
      for (int i = 0; i < int(n.x()); ++i) {
        const Vec3 c = box.min + b.res_ * Vec3(i + 0.5, j + 0.5, k + 0.5);
        if (!map.isFree(c)) b.rock_.push_back(c);
      }
  return b;
}

bool BruteForceDistance::isFree(const Vec3& p) const { return map_->isFree(p); }

DistanceSample BruteForceDistance::query(const Vec3& p) const {
  DistanceSample out;
  out.nearest = p;
  if (!allFinite(p) || !map_->isFree(p)) return out;
  const double half = 0.5 * res_;
  double best = std::numeric_limits<double>::infinity();
  Vec3 best_delta = Vec3::Zero();
  for (const Vec3& c : rock_) {
    const Vec3 d = p - c;
    const Vec3 delta = (d.array().abs() - half).max(0.0) * d.array().sign();
    const double d2 = delta.squaredNorm();
    if (d2 < best) { best = d2; best_delta = delta; }
  }
  if (!std::isfinite(best)) return out;
  out.in_rock = false;
  out.distance = std::sqrt(best);
  out.nearest = p - best_delta;
  if (out.distance > 0) out.gradient = best_delta / out.distance;
  return out;
}

}  // namespace adit::map
