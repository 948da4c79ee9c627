// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <array>
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

namespace {
// The vertical span of a band scan's column searches, in voxel keys: from a metre (and the
// slope's fall over the radius) below the robot's floor to the body's top at the radius.
struct BandSpan {
  std::int64_t k0 = 0, k1 = 0;
};
BandSpan bandSpan(double inv, double radius, double z_floor, double step_tol, double slope_tan, double height) {
  return {std::int64_t(std::floor((z_floor - 1.0 - radius * slope_tan) * inv)),
          std::int64_t(std::floor((z_floor + step_tol + radius * slope_tan + height) * inv))};
}
// floor(v) as a key, without a call into libm (this runs for every column of every scan);
// |v| is far below 2^62 here.
inline std::int64_t floorKey(double v) {
  const std::int64_t t = std::int64_t(v);
  return t - std::int64_t(double(t) > v);
}

// floorSlope's sample a of n along one side of its square of half-side `half_window`.
inline double sampleOffset(double half_window, int a, int n) { return half_window * (2.0 * a / (n - 1) - 1.0); }

// The band's bin of the direction (x, y): bin b covers azimuths from -pi + b 15 deg, as
// floor((atan2(y, x) + pi) / 15 deg), found by comparing with the bins' edges instead of an
// atan2 per column (this runs for every column of every scan).
inline __attribute__((always_inline)) int azimuthBin(double x, double y) {
  static_assert(BandScan::kBins == 24, "the edges below are 15 degrees apart");
  // The angle from -pi is the angle of (-x, -y) from the +x axis, in [0, 2 pi): its quadrant,
  // then the edges at 15, 30, 45, 60 and 75 degrees within it.
  const double u = -x, w = -y;
  double a = 0.0, c = 0.0;
  int quadrant = 0;
  if (u > 0.0 && w >= 0.0) {
    a = u, c = w, quadrant = 0;
  } else if (u <= 0.0 && w > 0.0) {
    a = w, c = -u, quadrant = 1;
  } else if (u < 0.0 && w <= 0.0) {
    a = -u, c = -w, quadrant = 2;
  } else if (u >= 0.0 && w < 0.0) {
    a = -w, c = u, quadrant = 3;
  } else {
    return BandScan::kBins / 2;  // (0, 0): atan2 gives 0
  }
  constexpr double kTan15 = 0.26794919243112270, kTan30 = 0.57735026918962576, kTan60 = 1.7320508075688772,
                   kTan75 = 3.7320508075688772;
  const int sub = int(c >= a * kTan15) + int(c >= a * kTan30) + int(c >= a) + int(c >= a * kTan60) + int(c >= a * kTan75);
  return std::min(BandScan::kBins - 1, 6 * quadrant + sub);
}

}  // namespace

bool BandCache::reserve(double resolution, double radius, double max_step, double slope_tan, double height) {
  *this = BandCache();
  if (!(resolution > 0.0) || !std::isfinite(resolution) || !(radius >= 0.0) || !std::isfinite(radius) ||
      !(max_step >= 0.0) || !std::isfinite(max_step) || !(slope_tan >= 0.0) || !std::isfinite(slope_tan) ||
      !(height > 0.0) || !std::isfinite(height))
    return false;
  const double inv = 1.0 / resolution;
  // A window spans at most 2 r / res + 2 columns a side: distinct columns of one scan never share
  // a slot of a ring that wide.
  const double ring = std::ceil(2.0 * radius * inv) + 3.0;
  const BandSpan span = bandSpan(inv, radius, 0.0, std::max(max_step, resolution) + 0.5 * resolution, slope_tan, height);
  // A column's searches fit with room for the floor to drift a few voxels before it is re-read.
  const double words = std::ceil(double(span.k1 - span.k0 + 2 + 16) / 64.0);
  const double bytes = ring * ring * (words * 16.0 + double(sizeof(Slot)));
  if (bytes > 64.0 * 1024 * 1024) return false;
  res_ = resolution;
  ring_ = std::int64_t(ring);
  words_ = std::int64_t(words);
  slots_.assign(std::size_t(ring_ * ring_), Slot());

  candidates_.assign(std::size_t(ring_ * ring_), Candidate());
  reach_.assign(64 * 64, 0.0);
  reach_n_ = 0;
  known_.assign(std::size_t(ring_ * ring_ * words_), 0);
  rock_.assign(known_.size(), 0);
  return true;
}

// One band scan's reads of the field's voxel columns: through the cache's bits when there is a
// cache, else voxel by voxel. Columns by key (ci, cj); the window is wi x wj columns from
// (i_lo, j_lo).
struct BandColumns {
  const DistanceField& field;
  BandCache* bc;
  double res, inv;
  std::int64_t i_lo, j_lo, wi, wj, ring, ring_i, ring_j;

  BandColumns(const DistanceField& f, BandCache* cache, std::int64_t i0, std::int64_t j0, std::int64_t w_i,
              std::int64_t w_j)
      : field(f), bc(cache), res(f.resolution()), inv(1.0 / res), i_lo(i0), j_lo(j0), wi(w_i), wj(w_j),
        ring(cache ? cache->ring_ : 1), ring_i(((i0 % ring) + ring) % ring), ring_j(((j0 % ring) + ring) % ring) {}

  // The cache, when it was sized for this field and a window of wi x wj columns fits its ring;
  // what it read is dropped when the field has changed since.
  static BandCache* usable(BandCache* cache, const DistanceField& f, std::int64_t w_i, std::int64_t w_j) {
    if (!cache || cache->empty() || !(std::abs(cache->res_ - f.resolution()) <= 1e-9 * f.resolution()) ||
        w_i > cache->ring_ || w_j > cache->ring_)
      return nullptr;
    if (cache->generation_ != f.generation()) {
      for (BandCache::Slot& sl : cache->slots_) sl.valid = false;
      cache->generation_ = f.generation();
    }
    return cache;
  }
  std::int64_t capacity() const { return bc ? bc->words_ * 64 : 0; }
  // The column's index in the cache's ring; -1 outside the window.
  std::int64_t slotOf(std::int64_t ci, std::int64_t cj) const {
    std::int64_t xi = ci - i_lo, yj = cj - j_lo;
    if (xi < 0 || xi >= wi || yj < 0 || yj >= wj) return -1;
    xi += ring_i;
    yj += ring_j;
    if (xi >= ring) xi -= ring;
    if (yj >= ring) yj -= ring;
    return xi * ring + yj;
  }
  Vec3 voxel(std::int64_t ci, std::int64_t cj, std::int64_t k) const {
    return Vec3((double(ci) + 0.5) * res, (double(cj) + 0.5) * res, (double(k) + 0.5) * res);
  }
  // The highest rock voxel of column (ci, cj) from key k_top down to k_bottom; k_bottom - 1 when
  // there is none. Every voxel read.
  std::int64_t direct(std::int64_t ci, std::int64_t cj, std::int64_t k_top, std::int64_t k_bottom) const {
    for (std::int64_t k = k_top; k >= k_bottom; --k)
      if (!field.isFree(voxel(ci, cj, k))) return k;
    return k_bottom - 1;
  }
  // The slot of column (ci, cj), its bits now holding k_bottom..k_top (emptied when it held
  // another column or another span).
  BandCache::Slot& slot(std::int64_t index, std::int64_t ci, std::int64_t cj, std::int64_t k_top, std::int64_t k_bottom) {
    BandCache::Slot& sl = bc->slots_[std::size_t(index)];
    const std::int64_t cap = capacity();
    if (!sl.valid || sl.i != ci || sl.j != cj || k_bottom < sl.k0 || k_top >= sl.k0 + cap) {
      sl.valid = true;
      sl.i = ci;
      sl.j = cj;
      sl.k0 = k_bottom - (cap - (k_top - k_bottom + 1)) / 2;  // room for the floor to drift either way
      sl.tops = 0;
      std::fill_n(bc->known_.data() + std::size_t(index * bc->words_), bc->words_, std::uint64_t(0));
      std::fill_n(bc->rock_.data() + std::size_t(index * bc->words_), bc->words_, std::uint64_t(0));
    }
    return sl;
  }
  // The same search through the slot's bits: each voxel read once while the column stays in the
  // ring, free runs skipped by their clearance.
  std::int64_t bits(std::int64_t index, const BandCache::Slot& sl, std::int64_t k_top, std::int64_t k_bottom) {
    std::uint64_t* kn = bc->known_.data() + std::size_t(index * bc->words_);
    std::uint64_t* rk = bc->rock_.data() + std::size_t(index * bc->words_);
    const std::int64_t lo = k_bottom - sl.k0;
    std::int64_t b = k_top - sl.k0;
    while (b >= lo) {
      const std::int64_t w = b >> 6, base = w * 64, from = std::max(lo, base);
      const int top = int(b - base), bottom = int(from - base);
      const std::uint64_t mask = (top == 63 ? ~std::uint64_t(0) : (std::uint64_t(1) << (top + 1)) - 1) &
                                 ~((std::uint64_t(1) << bottom) - 1);
      const std::uint64_t unknown = ~kn[w] & mask, rocky = kn[w] & rk[w] & mask;
      const int hu = unknown ? 63 - __builtin_clzll(unknown) : -1, hr = rocky ? 63 - __builtin_clzll(rocky) : -1;
      if (hr > hu) return sl.k0 + base + hr;  // every voxel above it in range is known free
      if (hu < 0) {
        b = from - 1;
        continue;
      }
      // Read the highest unknown voxel. Free: the voxels below it nearer than its clearance are
      // free too, and known so.
      const std::int64_t bit = base + hu;
      const double clear = field.voxelClearance(voxel(sl.i, sl.j, sl.k0 + bit));
      if (!(clear > 0.0)) {
        kn[w] |= std::uint64_t(1) << hu;
        rk[w] |= std::uint64_t(1) << hu;
        continue;
      }
      const std::int64_t skip = std::max<std::int64_t>(1, std::int64_t(std::ceil(clear * inv - 1e-6)));
      for (std::int64_t m = bit; m > bit - skip && m >= 0; --m) kn[m >> 6] |= std::uint64_t(1) << (m & 63);
      b = bit;
    }
    return k_bottom - 1;
  }
  std::int64_t firstRock(std::int64_t ci, std::int64_t cj, std::int64_t k_top, std::int64_t k_bottom) {
    if (!bc || k_top - k_bottom + 1 > capacity()) return direct(ci, cj, k_top, k_bottom);
    const std::int64_t index = slotOf(ci, cj);
    if (index < 0) return direct(ci, cj, k_top, k_bottom);
    return bits(index, slot(index, ci, cj, k_top, k_bottom), k_top, k_bottom);
  }
  // floorSlope's sample reaches hypot(u, v) tan + step + res for its n x n samples, kept in the
  // cache for the arguments last asked (n is at most 64: the table was sized by reserve()).
  const double* reaches(double half_window, int n, double slope_tan, double step) {
    BandCache& k = *bc;
    if (k.reach_n_ != n || k.reach_key_[0] != half_window || k.reach_key_[1] != slope_tan || k.reach_key_[2] != step) {
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          const double u = sampleOffset(half_window, a, n), v = sampleOffset(half_window, b, n);
          k.reach_[std::size_t(a * n + b)] = std::hypot(u, v) * slope_tan + step + res;
        }
      k.reach_n_ = n;
      k.reach_key_[0] = half_window;
      k.reach_key_[1] = slope_tan;
      k.reach_key_[2] = step;
    }
    return k.reach_.data();
  }
  // map::floorBelow through the cache (the same voxels, read once while they stay in the ring).
  std::optional<double> floorBelow(const Vec3& p, double depth) {
    const double lim = 32767.0 * res;  // the field's key space: beyond it, read as the field reads
    if (!allFinite(p) || !std::isfinite(depth) || depth > 1e6 || std::abs(p.z()) > 1e6 || !(std::abs(p.x()) <= lim) ||
        !(std::abs(p.y()) <= lim) || !(std::abs(p.z()) <= lim))
      return map::floorBelow(field, p, depth);
    const std::int64_t ci = floorKey(p.x() * inv), cj = floorKey(p.y() * inv), kp = floorKey(p.z() * inv);
    const std::int64_t n = floorKey(depth * inv) + 1;  // as std::floor: depth * inv is far below 2^62
    const std::int64_t k = firstRock(ci, cj, kp, kp - n);
    if (k == kp || k < kp - n) return std::nullopt;  // p in rock, or no floor within the depth
    return double(k + 1) * res;
  }
  // Column (ci, cj) of the window with its answers for tops t_lo..t_hi down to b_lo (made when
  // the slot holds none for these keys: the tops a search is made with change only when the
  // robot's floor moves a voxel) and the floors they can give.
  const BandCache::Slot& table(std::int64_t ci, std::int64_t cj, std::int64_t t_lo, std::int64_t t_hi, std::int64_t b_lo) {
    const std::int64_t index = slotOf(ci, cj);
    const BandCache::Slot& sl = bc->slots_[std::size_t(index)];
    return holdsTable(sl, ci, cj, t_lo, t_hi, b_lo) ? sl : makeTable(index, ci, cj, t_lo, t_hi, b_lo);
  }
  // The slot holds column (ci, cj)'s table for these keys (made with its bits holding b_lo..t_hi).
  static bool holdsTable(const BandCache::Slot& sl, std::int64_t ci, std::int64_t cj, std::int64_t t_lo,
                         std::int64_t t_hi, std::int64_t b_lo) {
    return sl.valid && sl.i == ci && sl.j == cj && sl.tops == t_hi - t_lo + 1 && sl.t_lo == t_lo && sl.b_lo == b_lo;
  }
  // The answer of every top when all are one floor (relative to b_lo: the highest rock at or
  // below the top top is below the lowest top); kMixed otherwise.
  static std::int8_t oneFloor(const BandCache::Slot& sl) {
    const std::int8_t h = sl.highest[sl.tops - 1];
    return h >= 0 && sl.b_lo + h < sl.t_lo ? h : BandCache::kMixed;
  }
  __attribute__((noinline)) const BandCache::Slot& makeTable(std::int64_t index, std::int64_t ci, std::int64_t cj,
                                                             std::int64_t t_lo, std::int64_t t_hi, std::int64_t b_lo) {
    BandCache::Slot& sl = slot(index, ci, cj, t_hi, b_lo);
    const std::int8_t tops = std::int8_t(t_hi - t_lo + 1);
    sl.t_lo = t_lo;
    sl.b_lo = b_lo;
    sl.tops = tops;
    sl.fmin = 1;
    sl.fmax = 0;
    std::int64_t h = bits(index, sl, t_hi, b_lo);
    for (std::int64_t t = t_hi; t >= t_lo; --t) {
      if (h > t) h = bits(index, sl, t, b_lo);  // the rock found was this top's upper neighbour
      sl.highest[t - t_lo] = std::int8_t(h - b_lo);
      if (h >= b_lo && h < t) {  // a floor (rock at the top is the body's band)
        const std::int8_t f = std::int8_t(h - b_lo);
        const bool none = sl.fmin > sl.fmax;
        sl.fmin = none ? f : std::min(sl.fmin, f);
        sl.fmax = none ? f : std::max(sl.fmax, f);
      }
    }
    return sl;
  }
};

void rockInBand(const DistanceField& field, const Vec3& centre, double radius, double z_floor, double max_step,
                double slope_tan, double height, BandScan& out, std::size_t max_window_columns,
                BandCache* cache, const BandBody* body) noexcept {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (int b = 0; b < BandScan::kBins; ++b) out.distance[b] = kInf;
  out.truncated = false;
  if (!allFinite(centre) || !std::isfinite(radius) || radius < 0.0 || !std::isfinite(z_floor) ||
      !(max_step >= 0.0) || !std::isfinite(max_step) || !(slope_tan >= 0.0) || !std::isfinite(slope_tan) ||
      !(height > 0.0) || !std::isfinite(height) || std::abs(z_floor) > 1e6 ||
      std::max(std::abs(centre.x()), std::abs(centre.y())) + radius > 1e6) {
    out.truncated = true;
    return;
  }
  const double res = field.resolution(), inv = 1.0 / res, half = 0.5 * res;
  const std::int64_t i_lo = floorKey((centre.x() - radius) * inv), i_hi = floorKey((centre.x() + radius) * inv);
  const std::int64_t j_lo = floorKey((centre.y() - radius) * inv), j_hi = floorKey((centre.y() + radius) * inv);
  const std::int64_t wi = i_hi - i_lo + 1, wj = j_hi - j_lo + 1;
  if (double(wi) * double(wj) > double(max_window_columns)) {
    out.truncated = true;
    return;
  }
  // The cache, when it was sized for this field and a window this wide; what it read is dropped
  // when the field has changed since.
  BandCache* const bc = BandColumns::usable(cache, field, wi, wj);
  BandColumns cols(field, bc, i_lo, j_lo, wi, wj);

  // A floor one voxel higher is the quantisation of any slope, never a step (coarse maps).
  const double step_tol = std::max(max_step, res) + half;
  const double baseline = std::max(1.0, 4.0 * res);  // slopes are measured over a metre
  auto topKey = [&](double s) { return floorKey((z_floor + step_tol + s * slope_tan + height) * inv); };
  auto bottomKey = [&](double s) { return floorKey((z_floor - 1.0 - s * slope_tan) * inv); };

  // Every search of this scan has its top in t_lo..t_hi and its bottom at or above b_lo (s runs
  // from 0 to the radius). With the cache each column of the window gets its table of answers
  // for those tops, and the floors they can give bound every step and slope test: a column whose
  // floor is within the safe number of voxels of every floor in the window passes them. (Rock at
  // the top of a search is never a floor when the body is taller than half a voxel: the top is
  // at least the body's height above the climbable height. Required here: taller than a voxel.)
  const std::int64_t t_lo = topKey(0.0), t_hi = topKey(radius), b_lo = bottomKey(radius);
  const bool tables = bc && height > res && t_hi - t_lo + 1 <= BandCache::kMaxTops && t_hi - b_lo + 1 <= cols.capacity() &&
                      t_hi - b_lo < 127;  // answers relative to b_lo fit a byte
  // The columns within the radius, by their nearest point's squared distance, with a margin over
  // the rounding of the square root the scan compares: a superset of those the scan takes, and
  // of those their step and slope tests look back at (on the line to the centre, nearer).
  const double radius2 = radius * radius * (1.0 + 1e-9) + 1e-12;
  // The point of column (i, j)'s square nearest the centre.
  auto nearestPoint = [&](std::int64_t i, std::int64_t j) __attribute__((always_inline)) {
    const double cx = (double(i) + 0.5) * res, cy = (double(j) + 0.5) * res;
    return std::array<double, 2>{std::clamp(centre.x(), cx - half, cx + half),
                                 std::clamp(centre.y(), cy - half, cy + half)};
  };
  auto squaredDistance = [&](std::int64_t i, std::int64_t j) __attribute__((always_inline)) {
    const std::array<double, 2> p = nearestPoint(i, j);
    const double ex = p[0] - centre.x(), ey = p[1] - centre.y();
    return ex * ex + ey * ey;
  };
  // Those columns, in the scan's order, for the pass below.
  std::int64_t fmin = std::numeric_limits<std::int64_t>::max(), fmax = std::numeric_limits<std::int64_t>::min();
  std::size_t candidates = 0;
  if (tables) {
    for (std::int64_t j = j_lo; j <= j_hi; ++j)
      for (std::int64_t i = i_lo; i <= i_hi; ++i) {
        const double q = squaredDistance(i, j);
        if (!(q <= radius2)) continue;
        const BandCache::Slot& sl = cols.table(i, j, t_lo, t_hi, b_lo);
        bc->candidates_[candidates++] = {std::int32_t(i - i_lo), std::int32_t(j - j_lo), BandColumns::oneFloor(sl), q};
        if (sl.fmin > sl.fmax) continue;
        fmin = std::min(fmin, b_lo + sl.fmin);
        fmax = std::max(fmax, b_lo + sl.fmax);
      }
  }
  // The most voxels two floors may differ by and still certainly pass a test "differ by more
  // than `limit`" (a micrometre of margin for the rounding of heights up to 1e6 m).
  auto safeVoxels = [&](double limit) {
    std::int64_t n = std::max<std::int64_t>(0, floorKey((limit - 1e-6) * inv));
    while (n > 0 && double(n) * res >= limit - 1e-6) --n;
    return double(n) * res < limit - 1e-6 ? n : std::int64_t(-1);
  };
  const std::int64_t safe_step = safeVoxels(step_tol), safe_slope = safeVoxels(baseline * slope_tan + res);
  // The floors (keys) on which a column passes every test at any distance from the centre: found
  // at every top (at or above the lowest bottom of the band), never above the climbable height,
  // near the robot's own floor within a step and a voxel, and within the safe voxels of every floor
  // in the window. A column whose answers are all one such floor is never in the way, unless it
  // is within the body's reach (the underside test): the scan passes it by without its distance.
  std::int64_t pass_lo = 1, pass_hi = 0;
  if (tables && fmin <= fmax) {
    const std::int64_t b_hi = bottomKey(0.0);
    for (std::int64_t k = fmin; k <= fmax; ++k) {
      const double cz = (double(k) + 0.5) * res;
      const bool passes = k >= b_hi && cz <= z_floor + step_tol && std::abs(cz + half - z_floor) <= res + max_step &&
                          std::max(k - fmin, fmax - k) <= std::min(safe_step, safe_slope);
      if (!passes) continue;
      if (pass_lo > pass_hi) pass_lo = k;
      pass_hi = k;
    }
  }
  // Within the body's reach, by the nearest point's squared distance (a margin over the rounding of
  // the square root the scan compares).
  const double reach2 = body ? body->reach * body->reach * (1.0 + 1e-9) + 1e-12 : -1.0;
  // A floor at height z, (dx, dy) from the centre, rises above the body's underside.
  auto aboveUnderside = [&](double z, double dx, double dy) __attribute__((always_inline)) {
    return z - (z_floor + body->grad_x * dx + body->grad_y * dy) > body->clearance + 1e-9;
  };

  // The highest rock of column (ci, cj) from key k_top down to k_bottom; k_bottom - 1 when there
  // is none.
  auto search = [&](std::int64_t ci, std::int64_t cj, std::int64_t k_top, std::int64_t k_bottom) __attribute__((always_inline)) {
    if (tables) {
      // Every column within the radius has its table for this scan; a search beyond them (none
      // is made: s stays within 0..radius, and the columns looked back at are nearer) reads the
      // field rather than disturb one.
      const std::int64_t slot = cols.slotOf(ci, cj);
      if (slot < 0 || k_top < t_lo || k_top > t_hi || k_bottom < b_lo) return cols.direct(ci, cj, k_top, k_bottom);
      const BandCache::Slot& sl = bc->slots_[std::size_t(slot)];
      if (!BandColumns::holdsTable(sl, ci, cj, t_lo, t_hi, b_lo)) return cols.direct(ci, cj, k_top, k_bottom);
      const std::int64_t h = b_lo + sl.highest[k_top - t_lo];
      return h >= k_bottom ? h : k_bottom - 1;
    }
    return cols.firstRock(ci, cj, k_top, k_bottom);
  };
  // The floor of the column (ci, cj), s metres out: the top of the highest rock voxel whose
  // centre is at most the climbable height there, searched down to a metre below the robot's
  // floor. `blocked` when rock stands above that floor within the body's height.
  struct Column {
    bool floor = false;
    double z = 0.0;
    bool blocked = false;
    std::int64_t k = 0;  // the floor's voxel
  };
  auto columnAt = [&](std::int64_t ci, std::int64_t cj, double s) __attribute__((always_inline)) {
    Column c;
    const double climb = z_floor + step_tol + s * slope_tan;
    const std::int64_t k_top = topKey(s), k_bottom = bottomKey(s);
    const std::int64_t k = search(ci, cj, k_top, k_bottom);
    if (k < k_bottom) return c;
    const double cz = (double(k) + 0.5) * res;
    if (cz > climb) {
      c.blocked = true;  // rock in the body's band (the floor is not searched further)
      return c;
    }
    c.floor = true;
    c.z = cz + half;
    c.k = k;
    return c;
  };
  auto column = [&](double x, double y, double s) { return columnAt(floorKey(x * inv), floorKey(y * inv), s); };
  // Nearest point of column (i, j) to the centre, its distance, and its bin.
  struct Near {
    double nx, ny, s;
    int bin;
  };
  auto nearOf = [&](std::int64_t i, std::int64_t j) __attribute__((always_inline)) {
    const double cx = (double(i) + 0.5) * res, cy = (double(j) + 0.5) * res;
    Near n;
    const std::array<double, 2> p = nearestPoint(i, j);
    n.nx = p[0];
    n.ny = p[1];
    const double ex = n.nx - centre.x(), ey = n.ny - centre.y();
    n.s = std::sqrt(ex * ex + ey * ey);
    n.bin = n.s > 1e-9 ? azimuthBin(ex, ey) : azimuthBin(cx - centre.x(), cy - centre.y());
    return n;
  };
  // Column (i, j): nearer than its bin's nearest so far and in the way, it becomes that.
  auto visit = [&](std::int64_t i, std::int64_t j) __attribute__((always_inline)) {
    const double cx = (double(i) + 0.5) * res, cy = (double(j) + 0.5) * res;
    const Near n = nearOf(i, j);
    const double s = n.s;
    const int b = n.bin;
    if (s > radius) return;
    if (s >= out.distance[b]) return;  // this column cannot be nearer in its bin
    const Column c = columnAt(i, j, s);
    bool way = c.blocked || !c.floor;
    const double dx = cx - centre.x(), dy = cy - centre.y();
    if (!way && body && s <= body->reach && aboveUnderside(c.z, dx, dy)) way = true;
    // No floor in the window further from this one than these voxels: its tests pass.
    const std::int64_t apart =
        tables && !way && fmin <= c.k && c.k <= fmax ? std::max(c.k - fmin, fmax - c.k) : std::int64_t(-1);
    const bool slope_passes = apart >= 0 && apart <= safe_slope, step_passes = apart >= 0 && apart <= safe_step;
    // The centre's distance, for the tests that look back toward it.
    auto centreDistance = [&] { return std::max(std::sqrt(dx * dx + dy * dy), 1e-9); };
    if (!way && s >= baseline) {
      // A slope steeper than allowed: against the column a baseline nearer the robot (a voxel of
      // quantisation over the baseline; a step within max_step on a flat baseline passes).
      if (!slope_passes) {
        const double d = centreDistance();
        const Column back = column(cx - dx / d * baseline, cy - dy / d * baseline, s - baseline);
        if (back.floor && std::abs(c.z - back.z) > baseline * slope_tan + res) way = true;
      }
    } else if (!way && s >= 4.0 * res) {
      // Nearer than a baseline: against the robot's own floor, steps within max_step allowed.
      if (std::abs(c.z - z_floor) > s * slope_tan + res + max_step) way = true;
    }
    if (!way && s > res && !step_passes) {
      // A step: against the next column toward the robot.
      const double d = centreDistance();
      const Column inner = column(cx - dx / d * res, cy - dy / d * res, std::max(0.0, s - res));
      if (inner.floor && std::abs(c.z - inner.z) > step_tol) way = true;
    }
    if (!way) return;
    out.distance[b] = s;
    out.point[b] = Vec3(n.nx, n.ny, z_floor);
  };
  if (!tables) {
    for (std::int64_t j = j_lo; j <= j_hi; ++j)
      for (std::int64_t i = i_lo; i <= i_hi; ++i) visit(i, j);
    return;
  }
  for (std::size_t k = 0; k < candidates; ++k) {
    const BandCache::Candidate& cd = bc->candidates_[k];
    const std::int64_t i = i_lo + cd.di, j = j_lo + cd.dj;
    if (pass_lo <= pass_hi && cd.uniform != BandCache::kMixed && b_lo + cd.uniform >= pass_lo &&
        b_lo + cd.uniform <= pass_hi) {
      if (!(cd.q <= reach2)) continue;  // never in the way
      // Within reach: in the way only if it rises above the underside (the test in visit()).
      const double z = (double(b_lo + cd.uniform) + 0.5) * res + half;
      if (!aboveUnderside(z, (double(i) + 0.5) * res - centre.x(), (double(j) + 0.5) * res - centre.y())) continue;
    }
    visit(i, j);
  }
}

std::optional<double> floorBelow(const DistanceField& field, const Vec3& p, double depth) noexcept {
  if (!allFinite(p) || !std::isfinite(depth) || depth > 1e6 || std::abs(p.z()) > 1e6 || !field.isFree(p))
    return std::nullopt;
  const double res = field.resolution(), inv = 1.0 / res;
  // The voxels under p's own, read at their centres: a sample on the face between two voxels (p
  // half a body above a floor that is itself on a face, a common case) reads whichever voxel
  // rounding picks, and the floor came out a voxel low: the ground planner then found no place
  // to stand on six district roadways (tests/map/band_scan_test.cpp, FloorBelow*).
  const std::int64_t k0 = floorKey(p.z() * inv);
  const std::int64_t n = std::int64_t(std::floor(depth * inv)) + 1;
  for (std::int64_t i = 1; i <= n; ++i) {
    const std::int64_t k = k0 - i;
    if (!field.isFree(Vec3(p.x(), p.y(), (double(k) + 0.5) * res))) return double(k + 1) * res;
  }
  return std::nullopt;
}

FloorSlope floorSlope(const DistanceField& field, const Vec3& at, double yaw, double half_window, double slope_tan,
                      double step, int n, BandCache* cache) noexcept {
  FloorSlope out;
  if (!allFinite(at) || !std::isfinite(yaw) || !(half_window > 0.0) || half_window > 1e3 || n < 2 || n > 64) return out;
  const double res = field.resolution(), inv = 1.0 / res;
  const double c = std::cos(yaw), s = std::sin(yaw);
  // The samples' columns, for the cache: a window of the turned square's extent.
  const double ext = half_window * (std::abs(c) + std::abs(s));
  const bool near = std::max(std::abs(at.x()), std::abs(at.y())) + ext < 1e6;
  const std::int64_t i_lo = near ? floorKey((at.x() - ext) * inv) : 0, j_lo = near ? floorKey((at.y() - ext) * inv) : 0;
  const std::int64_t wi = near ? floorKey((at.x() + ext) * inv) - i_lo + 1 : 0;
  const std::int64_t wj = near ? floorKey((at.y() + ext) * inv) - j_lo + 1 : 0;
  BandColumns cols(field, near ? BandColumns::usable(cache, field, wi, wj) : nullptr, i_lo, j_lo, wi, wj);
  // Each sample's reach above and below the centre's floor, made once for these arguments (a
  // hypot per sample, the same numbers every period).
  const double* reach_of = cols.bc ? cols.reaches(half_window, n, slope_tan, step) : nullptr;
  // Normal equations of z = z0 + along * u + across * v over the samples (u, v in the body frame).
  double suu = 0, svv = 0, suv = 0, su = 0, sv = 0, sz = 0, suz = 0, svz = 0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double u = sampleOffset(half_window, a, n), v = sampleOffset(half_window, b, n);
      const double reach = reach_of ? reach_of[a * n + b] : std::hypot(u, v) * slope_tan + step + res;
      const Vec3 top(at.x() + u * c - v * s, at.y() + u * s + v * c, at.z() + reach);
      const std::optional<double> f = cols.bc ? cols.floorBelow(top, 2.0 * reach) : floorBelow(field, top, 2.0 * reach);
      if (!f || std::abs(*f - at.z()) > reach) continue;
      const double z = *f - at.z();
      ++out.samples;
      suu += u * u, svv += v * v, suv += u * v, su += u, sv += v, sz += z, suz += u * z, svz += v * z;
    }
  const double m = out.samples;
  // Centred sums: the plane's offset drops out, leaving a 2 x 2 system for the two slopes.
  const double cuu = suu - su * su / std::max(m, 1.0), cvv = svv - sv * sv / std::max(m, 1.0);
  const double cuv = suv - su * sv / std::max(m, 1.0);
  const double cuz = suz - su * sz / std::max(m, 1.0), cvz = svz - sv * sz / std::max(m, 1.0);
  const double det = cuu * cvv - cuv * cuv;
  // Samples along one line (or fewer than three) do not fix a plane.
  if (out.samples < 3 || det <= 1e-9 * std::max(cuu * cvv, 1e-12)) return out;
  out.along = (cuz * cvv - cvz * cuv) / det;
  out.across = (cvz * cuu - cuz * cuv) / det;
  return out;
}

}  // namespace adit::map
