// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace adit::map {

RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, Vec3* out,
                                   std::size_t capacity, std::size_t max_window_voxels) noexcept {
  return rockSurfacePoints(field, centre, radius, ViewCone{}, out, capacity, max_window_voxels);
}

RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, const ViewCone& cone,
                                   Vec3* out, std::size_t capacity, std::size_t max_window_voxels) noexcept {
  RockPointsResult r;
  const double axis_norm = cone.axis.norm();
  const bool use_cone = std::isfinite(axis_norm) && axis_norm > 1e-12 && cone.half_angle_rad < 3.14159265358979;
  const Vec3 axis = use_cone ? Vec3(cone.axis / axis_norm) : Vec3::Zero();
  const double cos_half = std::cos(cone.half_angle_rad);
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
  // Each voxel is read from the field once: a rock voxel's 6 neighbours are mostly voxels the
  // scan reads anyway. 2 bits per voxel (unread, free, rock) in a 16 KiB stack buffer when the
  // window grown by one voxel fits, else uncached.
  constexpr std::int64_t kCacheVoxels = 1 << 16;
  std::uint8_t cache[kCacheVoxels / 4];
  const std::int64_t n0 = hi[0] - lo[0] + 3, n1 = hi[1] - lo[1] + 3, n2 = hi[2] - lo[2] + 3;
  const bool cached = n0 * n1 * n2 <= kCacheVoxels;
  if (cached) std::memset(cache, 0, std::size_t((n0 * n1 * n2 + 3) / 4));
  auto isRock = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    const Vec3 c((double(i) + 0.5) * res, (double(j) + 0.5) * res, (double(k) + 0.5) * res);
    if (!cached) return !field.isFree(c);
    const std::int64_t idx = (i - lo[0] + 1) + n0 * ((j - lo[1] + 1) + n1 * (k - lo[2] + 1));
    std::uint8_t& byte = cache[idx >> 2];
    const int shift = int(idx & 3) * 2;
    const int st = (byte >> shift) & 3;
    if (st != 0) return st == 2;
    const bool rock = !field.isFree(c);
    byte = std::uint8_t(byte | ((rock ? 2 : 1) << shift));
    return rock;
  };
  // Per x-row only the voxels in the shell between the known-free ball and the radius are
  // visited; the limits err outwards (a voxel is visited rather than missed) and every visited
  // voxel still gets the exact tests below.
  constexpr double kSlack = 1e-9;
  auto gap = [half](double c, double o) { return std::max(std::abs(c - o) - half, 0.0); };
  for (std::int64_t k = lo[2]; k <= hi[2]; ++k) {
    const double cz = (double(k) + 0.5) * res;
    const double gz = gap(cz, centre.z());
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j) {
      const double cy = (double(j) + 0.5) * res;
      const double gy = gap(cy, centre.y());
      const double rem = radius * radius - gy * gy - gz * gz;
      if (rem < -kSlack) continue;
      const double w = std::sqrt(std::max(rem, 0.0)) + half + kSlack;
      const std::int64_t i_lo = std::max(lo[0], std::int64_t(std::ceil((centre.x() - w) * inv - 0.5)));
      const std::int64_t i_hi = std::min(hi[0], std::int64_t(std::floor((centre.x() + w) * inv - 0.5)));
      std::int64_t skip_lo = 1, skip_hi = 0;  // voxels surely inside the free ball: none yet
      const double rem_in = clear * clear - gy * gy - gz * gz;
      if (rem_in > 0.0) {
        const double w_in = std::sqrt(rem_in) + half - kSlack;
        skip_lo = std::int64_t(std::ceil((centre.x() - w_in) * inv - 0.5)) + 1;
        skip_hi = std::int64_t(std::floor((centre.x() + w_in) * inv - 0.5)) - 1;
      }
      for (std::int64_t i = i_lo; i <= i_hi; ++i) {
        if (i == skip_lo && skip_lo <= skip_hi) {
          i = skip_hi;
          continue;
        }
        const double cx = (double(i) + 0.5) * res;
        const Vec3 c(cx, cy, cz);
        const Vec3 nearest = centre.cwiseMax(c - Vec3::Constant(half)).cwiseMin(c + Vec3::Constant(half));
        const Vec3 off = nearest - centre;
        const double d2 = off.squaredNorm();
        if (d2 > radius * radius || d2 < clear * clear) continue;
        if (use_cone && d2 > 0.0) {
          // dot >= cos * |off| without the square root: compare squares, minding the signs.
          const double dot = off.dot(axis), cmin = cos_half - 1e-12;
          const bool inside = cmin >= 0.0 ? (dot >= 0.0 && dot * dot >= cmin * cmin * d2)
                                          : (dot >= 0.0 || dot * dot <= cmin * cmin * d2);
          if (!inside) continue;
        }
        if (!isRock(i, j, k)) continue;
        if (isRock(i - 1, j, k) && isRock(i + 1, j, k) && isRock(i, j - 1, k) && isRock(i, j + 1, k) &&
            isRock(i, j, k - 1) && isRock(i, j, k + 1))
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
