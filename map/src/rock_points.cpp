// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

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

void rockInBand(const DistanceField& field, const Vec3& centre, double radius, double z_floor, double max_step,
                double slope_tan, double height, BandScan& out, std::size_t max_window_columns) noexcept {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kTwoPi = 6.28318530717958647692;
  for (int b = 0; b < BandScan::kBins; ++b) out.distance[b] = kInf;
  out.truncated = false;
  if (!allFinite(centre) || !std::isfinite(radius) || radius < 0.0 || !std::isfinite(z_floor) ||
      !(max_step >= 0.0) || !std::isfinite(max_step) || !(slope_tan >= 0.0) || !std::isfinite(slope_tan) ||
      !(height > 0.0) || !std::isfinite(height)) {
    out.truncated = true;
    return;
  }
  const double res = field.resolution(), inv = 1.0 / res, half = 0.5 * res;
  const std::int64_t i_lo = std::int64_t(std::floor((centre.x() - radius) * inv));
  const std::int64_t i_hi = std::int64_t(std::floor((centre.x() + radius) * inv));
  const std::int64_t j_lo = std::int64_t(std::floor((centre.y() - radius) * inv));
  const std::int64_t j_hi = std::int64_t(std::floor((centre.y() + radius) * inv));
  if (double(i_hi - i_lo + 1) * double(j_hi - j_lo + 1) > double(max_window_columns)) {
    out.truncated = true;
    return;
  }
  // A floor one voxel higher is the quantisation of any slope, never a step (coarse maps).
  const double step_tol = std::max(max_step, res) + half;
  const double baseline = std::max(1.0, 4.0 * res);  // slopes are measured over a metre
  // The floor of the column at (x, y), s metres out: the top of the highest rock voxel whose
  // centre is at most the climbable height there, searched down to a metre below the robot's
  // floor. `blocked` when rock stands above that floor within the body's height.
  struct Column {
    bool floor = false;
    double z = 0.0;
    bool blocked = false;
  };
  auto column = [&](double x, double y, double s) {
    Column c;
    const double climb = z_floor + step_tol + s * slope_tan;
    const std::int64_t k_top = std::int64_t(std::floor((climb + height) * inv));
    const std::int64_t k_bottom = std::int64_t(std::floor((z_floor - 1.0 - s * slope_tan) * inv));
    for (std::int64_t k = k_top; k >= k_bottom; --k) {
      const double cz = (double(k) + 0.5) * res;
      if (field.isFree(Vec3(x, y, cz))) continue;
      if (cz > climb) {
        c.blocked = true;  // rock in the body's band (the floor is not searched further)
        return c;
      }
      c.floor = true;
      c.z = cz + half;
      return c;
    }
    return c;
  };
  for (std::int64_t j = j_lo; j <= j_hi; ++j) {
    const double cy = (double(j) + 0.5) * res;
    for (std::int64_t i = i_lo; i <= i_hi; ++i) {
      const double cx = (double(i) + 0.5) * res;
      const double nx = std::clamp(centre.x(), cx - half, cx + half), ny = std::clamp(centre.y(), cy - half, cy + half);
      const double s = std::hypot(nx - centre.x(), ny - centre.y());
      if (s > radius) continue;
      const double dx = cx - centre.x(), dy = cy - centre.y();
      const double az = s > 1e-9 ? std::atan2(ny - centre.y(), nx - centre.x()) : std::atan2(dy, dx);
      const int b = std::min(BandScan::kBins - 1, std::max(0, int((az + 0.5 * kTwoPi) / kTwoPi * BandScan::kBins)));
      if (s >= out.distance[b]) continue;  // this column cannot be nearer in its bin
      const Column c = column(cx, cy, s);
      bool way = c.blocked || !c.floor;
      const double d = std::max(std::hypot(dx, dy), 1e-9);
      if (!way && s >= baseline) {
        // A slope steeper than allowed: against the column a baseline nearer the robot (a voxel of
        // quantisation over the baseline; a step within max_step on a flat baseline passes).
        const Column back = column(cx - dx / d * baseline, cy - dy / d * baseline, s - baseline);
        if (back.floor && std::abs(c.z - back.z) > baseline * slope_tan + res) way = true;
      } else if (!way && s >= 4.0 * res) {
        // Nearer than a baseline: against the robot's own floor, steps within max_step allowed.
        if (std::abs(c.z - z_floor) > s * slope_tan + res + max_step) way = true;
      }
      if (!way && s > res) {
        // A step: against the next column toward the robot.
        const Column inner = column(cx - dx / d * res, cy - dy / d * res, std::max(0.0, s - res));
        if (inner.floor && std::abs(c.z - inner.z) > step_tol) way = true;
      }
      if (!way) continue;
      out.distance[b] = s;
      out.point[b] = Vec3(nx, ny, z_floor);
    }
  }
}

std::optional<double> floorBelow(const DistanceField& field, const Vec3& p, double depth) noexcept {
  if (!allFinite(p) || !std::isfinite(depth) || !field.isFree(p)) return std::nullopt;
  const double res = field.resolution();
  for (double dz = res; dz <= depth + res; dz += res) {
    const Vec3 q = p - Vec3(0, 0, dz);
    if (!field.isFree(q)) return (std::floor(q.z() / res) + 1.0) * res;
  }
  return std::nullopt;
}

}  // namespace adit::map
