// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace adit::map {

RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, Vec3* out,
                                   std::size_t capacity, std::size_t max_window_voxels) noexcept {
  RockPointsResult r;
  if (!allFinite(centre) || !std::isfinite(radius) || radius < 0.0) {
    r.truncated = true;
    return r;
  }
  const double res = field.resolution(), inv = 1.0 / res, half = 0.5 * res;
  std::int64_t lo[3], hi[3];
  double count = 1.0;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::int64_t(std::floor((centre[a] - radius) * inv));
    hi[a] = std::int64_t(std::floor((centre[a] + radius) * inv));
    count *= double(hi[a] - lo[a] + 1);
  }
  if (count > double(max_window_voxels)) {
    r.truncated = true;
    return r;
  }
  // The field's distance is an upper bound within half a voxel; one voxel of margin keeps the
  // skipped ball inside the free space.
  const double clear = std::max(0.0, field.distance(centre) - res);
  if (clear > radius) return r;  // everything within the radius is free
  auto isRock = [&](double x, double y, double z) { return !field.isFree(Vec3(x, y, z)); };
  for (std::int64_t k = lo[2]; k <= hi[2]; ++k) {
    const double cz = (double(k) + 0.5) * res;
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j) {
      const double cy = (double(j) + 0.5) * res;
      for (std::int64_t i = lo[0]; i <= hi[0]; ++i) {
        const double cx = (double(i) + 0.5) * res;
        const Vec3 c(cx, cy, cz);
        const Vec3 nearest = centre.cwiseMax(c - Vec3::Constant(half)).cwiseMin(c + Vec3::Constant(half));
        const double d = (nearest - centre).norm();
        if (d > radius || d < clear) continue;
        if (!isRock(cx, cy, cz)) continue;
        if (isRock(cx - res, cy, cz) && isRock(cx + res, cy, cz) && isRock(cx, cy - res, cz) &&
            isRock(cx, cy + res, cz) && isRock(cx, cy, cz - res) && isRock(cx, cy, cz + res))
          continue;  // interior rock
        if (r.written < capacity) out[r.written++] = nearest;
        ++r.found;
      }
    }
  }
  r.truncated = r.found > r.written;
  return r;
}

}  // namespace adit::map
