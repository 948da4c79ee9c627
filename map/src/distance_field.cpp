// SPDX-License-Identifier: BSD-3-Clause
// Sparse exact Euclidean feature transform. See distance_field.hpp for the contract.
#include "adit/map/distance_field.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <tuple>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "distance_field_impl.hpp"

namespace adit::map {


namespace {
// Process-wide, so that a generation names one content of one field, whichever object holds it.
std::uint64_t nextGeneration() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}
}  // namespace

// Squared distance (voxels^2) from voxel (x, y, z)'s centre to its stored nearest rock voxel's:
// 0 for rock, infinity for a free voxel whose site the transform does not know.
double DistanceField::Impl::storedClearance2(int x, int y, int z) const {
  const Cell c = cell(x, y, z);
  if (!isFreeCell(c)) return 0.0;
  if (!hasSite(c)) return std::numeric_limits<double>::infinity();
  const std::uint64_t site = siteOf(c, x, y, z);
  const double dx = keyCoord(site, 0) - x, dy = keyCoord(site, 1) - y, dz = keyCoord(site, 2) - z;
  return dx * dx + dy * dy + dz * dz;
}

// How far beyond the changed box w update() must rewrite voxels, from the field as it stands
// (before w is re-read): the smallest g < grow_max such that every voxel at Chebyshev distance g
// from w has a stored clearance below g - sqrt(1/2) voxels, else grow_max (the map's largest
// clearance, which bounds every voxel). `max_d2` gets the largest squared clearance in w grown by
// the g returned, w included (for the transform's margin), or infinity when g is grow_max.
//
// Why: a voxel v can change only if the change comes as near it as its own nearest rock,
// dist(v, w) <= D(v) (update()'s comment), D being the centre-to-centre distance to the nearest
// rock voxel. D is 1-Lipschitz and dist(x, w) falls at rate 1 along the segment from x to the
// nearest point of w, so D - dist(., w) only grows along it. If v lies beyond w grown by g, the
// segment crosses that box's face at some x with D(x) >= dist(x, w) >= g, and the face's voxel
// centre nearest x (within sqrt(1/2) voxel, in the face's plane) has D >= g - sqrt(1/2). Where
// no face voxel reaches that, no voxel beyond changes. In a roadway the clearances are its half
// width, not the largest chamber's, and the rewritten box shrinks accordingly.
int DistanceField::Impl::localGrow(const BoxI& w, int grow_max, double& max_d2) const {
  const int* lo = w.lo;
  const int* hi = w.hi;
  constexpr double kFaceSlack = 0.70711;  // sqrt(1/2), rounded up
  double worst = 0.0;
  for (int g = 0; g < grow_max; ++g) {
    double layer = 0.0;
    const int zl = std::max(0, lo[2] - g), zh = std::min(65535, hi[2] + g);
    const int yl = std::max(0, lo[1] - g), yh = std::min(65535, hi[1] + g);
    const int xl = std::max(0, lo[0] - g), xh = std::min(65535, hi[0] + g);
    for (int z = zl; z <= zh; ++z)
      for (int y = yl; y <= yh; ++y) {
        // Inside the box of the layers already read, only the two ends of the row are new.
        const bool inner = g > 0 && z > lo[2] - g && z < hi[2] + g && y > lo[1] - g && y < hi[1] + g;
        if (inner) {
          if (lo[0] - g >= 0) layer = std::max(layer, storedClearance2(lo[0] - g, y, z));
          if (hi[0] + g <= 65535) layer = std::max(layer, storedClearance2(hi[0] + g, y, z));
        } else {
          for (int x = xl; x <= xh; ++x) layer = std::max(layer, storedClearance2(x, y, z));
        }
      }
    worst = std::max(worst, layer);
    const double bound = double(g) - kFaceSlack;
    if (g > 0 && layer < bound * bound) {
      max_d2 = worst;
      return g;
    }
    if (!(worst < std::numeric_limits<double>::infinity())) break;  // an unknown site: no local proof
  }
  max_d2 = std::numeric_limits<double>::infinity();
  return grow_max;
}

DistanceField::DistanceField(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) { impl_->generation = nextGeneration(); }
DistanceField::DistanceField(DistanceField&&) noexcept = default;
DistanceField& DistanceField::operator=(DistanceField&&) noexcept = default;
DistanceField::DistanceField(const DistanceField& o) : impl_(std::make_unique<Impl>(*o.impl_)) {}
DistanceField& DistanceField::operator=(const DistanceField& o) {
  if (this != &o) impl_ = std::make_unique<Impl>(*o.impl_);
  return *this;
}
DistanceField::~DistanceField() = default;

double DistanceField::resolution() const { return impl_->res; }
std::uint64_t DistanceField::generation() const noexcept { return impl_->generation; }
const DistanceFieldStats& DistanceField::stats() const { return impl_->stats; }

StatusOr<DistanceField> DistanceField::build(const OccupancyMap& map, const ProgressFn& progress,
                                             std::uint64_t max_blocks) {
  const auto t0 = std::chrono::steady_clock::now();
  auto impl = std::make_unique<Impl>();
  impl->res = map.resolution();
  impl->inv = 1.0 / impl->res;
  const double res = impl->res, inv = impl->inv;
  const octomap::OcTree& tree = map.octree();

  // Free voxels: free leaves, plus (policy kFree) the unknown inside the bounds.
  const bool unknown_free = map.unknownPolicy() == UnknownPolicy::kFree && !map.bounds().empty();
  BoxI bounds_keys{};
  if (unknown_free) {
    for (int a = 0; a < 3; ++a) {
      bounds_keys.lo[a] = keyOf(map.bounds().min[a] + 0.5 * res, inv);
      bounds_keys.hi[a] = keyOf(map.bounds().max[a] - 0.5 * res, inv);
    }
  }

  // One walk of the octree marks the free voxels in a bit set (a bit per voxel, in 16^3 blocks);
  // the tiles are then laid out block by block in index order, so that neighbouring tiles sit
  // close in memory, and only tiles with a free voxel are allocated.
  internal::BitVoxelSet free_set;
  std::uint64_t last_key = ~std::uint64_t{0};
  internal::BitVoxelSet::Block* last_block = nullptr;
  bool overflow = false;
  auto block = [&](int bx, int by, int bz) -> internal::BitVoxelSet::Block* {
    const std::uint64_t key = internal::packBlock(bx, by, bz);
    if (key == last_key) return last_block;
    if (free_set.blockCount() >= max_blocks && !free_set.find(bx, by, bz)) { overflow = true; return nullptr; }
    last_key = key;
    last_block = &free_set.block(bx, by, bz);  // valid until the next new block
    return last_block;
  };
  // Sets a box of voxels free (or rock), a row of up to 16 voxels at a time.
  auto mark = [&](const int box_lo[3], const int box_hi[3], bool free) {
    // Keys 0 and 65535 stay rock, so every line of the transform ends in rock inside the key range.
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(box_lo[a], 1);
      hi[a] = std::min(box_hi[a], 65534);
      if (lo[a] > hi[a]) return;
    }
    for (int bz = lo[2] >> kBlockBits; bz <= hi[2] >> kBlockBits && !overflow; ++bz)
      for (int by = lo[1] >> kBlockBits; by <= hi[1] >> kBlockBits && !overflow; ++by)
        for (int bx = lo[0] >> kBlockBits; bx <= hi[0] >> kBlockBits && !overflow; ++bx) {
          internal::BitVoxelSet::Block* blk = block(bx, by, bz);
          if (!blk) return;
          const int x0 = std::max(lo[0], bx << kBlockBits), x1 = std::min(hi[0], (bx << kBlockBits) + kBlockMask);
          const int y0 = std::max(lo[1], by << kBlockBits), y1 = std::min(hi[1], (by << kBlockBits) + kBlockMask);
          const int z0 = std::max(lo[2], bz << kBlockBits), z1 = std::min(hi[2], (bz << kBlockBits) + kBlockMask);
          const auto bits = std::uint16_t(((1u << (x1 - x0 + 1)) - 1u) << (x0 & kBlockMask));
          for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y) {
              std::uint16_t& row = (*blk)[std::size_t((y & kBlockMask) + kBlockSize * (z & kBlockMask))];
              row = free ? std::uint16_t(row | bits) : std::uint16_t(row & ~bits);
            }
        }
  };
  if (unknown_free) {
    const double blocks_needed = std::ceil((bounds_keys.hi[0] - bounds_keys.lo[0] + 1) / 16.0 + 1) *
                                 std::ceil((bounds_keys.hi[1] - bounds_keys.lo[1] + 1) / 16.0 + 1) *
                                 std::ceil((bounds_keys.hi[2] - bounds_keys.lo[2] + 1) / 16.0 + 1);
    if (blocks_needed > double(max_blocks))
      return outOfRange("distance field: treating unknown space as free needs about " +
                        std::to_string(std::uint64_t(blocks_needed)) + " tiles of 16^3 voxels (limit " +
                        std::to_string(max_blocks) + "); use --unknown rock or a coarser map");
    mark(bounds_keys.lo, bounds_keys.hi, true);
    // Occupied leaves inside the bounds only: the blocks there exist already.
    visitLeaves(tree, [&](const int lo[3], int size, bool occupied) {
      if (!occupied) return;
      const int hi[3] = {lo[0] + size - 1, lo[1] + size - 1, lo[2] + size - 1};
      int clo[3], chi[3];
      for (int a = 0; a < 3; ++a) {
        clo[a] = std::max(lo[a], bounds_keys.lo[a]);
        chi[a] = std::min(hi[a], bounds_keys.hi[a]);
        if (clo[a] > chi[a]) return;
      }
      mark(clo, chi, false);
    });
  } else {
    visitLeaves(tree, [&](const int lo[3], int size, bool occupied) {
      if (occupied || overflow) return;
      if (std::pow(double(size) / kBlockSize, 3.0) > double(max_blocks)) { overflow = true; return; }
      const int hi[3] = {lo[0] + size - 1, lo[1] + size - 1, lo[2] + size - 1};
      mark(lo, hi, true);
    });
  }
  if (overflow)
    return outOfRange("distance field: the free space needs more than " + std::to_string(max_blocks) +
                      " tiles of 16^3 voxels (" + std::to_string(max_blocks * 16 / 1024) + " MiB)");
  // Blocks in index order (z, y, x); per block, its tiles that hold a free voxel.
  std::vector<std::uint32_t> order(free_set.blockCount());
  for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const auto& ca = free_set.blockCoord(a);
    const auto& cb = free_set.blockCoord(b);
    return std::tie(ca[2], ca[1], ca[0]) < std::tie(cb[2], cb[1], cb[0]);
  });
  auto tileRows = [](const internal::BitVoxelSet::Block& blk, int j, auto&& fn) {
    const int sx = (j & kSubMask) << kTileBits, sy = ((j >> kSubBits) & kSubMask) << kTileBits,
              sz = (j >> (2 * kSubBits)) << kTileBits;
    for (int z = 0; z < kTileSize; ++z)
      for (int y = 0; y < kTileSize; ++y)
        fn(y, z, unsigned(blk[std::size_t((sy + y) + kBlockSize * (sz + z))] >> sx) & ((1u << kTileSize) - 1u));
  };
  if (order.empty()) return failedPrecondition("distance field: the map has no free voxel");
  std::size_t tile_count = 0;
  for (std::uint32_t i : order)
    for (int j = 0; j < kTilesPerBlock; ++j) {
      unsigned any = 0;
      tileRows(free_set.blockAt(i), j, [&](int, int, unsigned bits) { any |= bits; });
      tile_count += any ? 1 : 0;
    }
  impl->tiles.reserve(tile_count + 1);
  adviseHugePages(impl->tiles);
  impl->appendTile();  // kRockTile
  for (std::uint32_t i : order) {
    const internal::BitVoxelSet::Block& blk = free_set.blockAt(i);
    // Every block the walk touched gets a region, even one that ended all rock (unknown space
    // inside the bounds, cleared again by an occupied leaf): a region costs 44 bytes, and the
    // block count stays what estimateDistanceField() predicts.
    const std::int32_t region = impl->appendRegion(free_set.blockCoord(i));
    for (int j = 0; j < kTilesPerBlock; ++j) {
      unsigned any = 0;
      tileRows(blk, j, [&](int, int, unsigned bits) { any |= bits; });
      if (!any) continue;
      const std::int32_t t = impl->appendTile();
      impl->regions[std::size_t(region)][std::size_t(j)] = t;
      Tile& tile = impl->tiles[std::size_t(t)];
      tileRows(blk, j, [&](int y, int z, unsigned bits) {
        for (int x = 0; x < kTileSize; ++x)
          tile[std::size_t(localIndex(x, y, z))] = (bits >> x) & 1u ? kFreeBit : 0;
      });
    }
  }
  ADIT_RETURN_IF_ERROR(impl->rebuildIndex());
  if (progress) progress("reading free space", 1.0);
  const auto t1 = std::chrono::steady_clock::now();
  impl->transformAll(progress);
  if (impl->far_overflow)
    return outOfRange("distance field: more than " + std::to_string(kMaxFarSites) +
                      " free voxels lie farther from rock than the cells reach; use a coarser resolution");
  const auto t2 = std::chrono::steady_clock::now();
  impl->refreshStats();
  impl->stats.transform_seconds = std::chrono::duration<double>(t2 - t1).count();
  impl->stats.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return DistanceField(std::move(impl));
}

StatusOr<DistanceField> DistanceField::buildWithNearLimitForTesting(const OccupancyMap& map, int max_offset) {
  if (max_offset < 0 || max_offset > kOffsetMax) return invalidArgument("near limit out of range");
  ADIT_ASSIGN_OR_RETURN(DistanceField f, DistanceField::build(map));
  f.impl_->near_limit = max_offset;
  f.impl_->transformAll({});
  f.impl_->refreshStats();
  f.impl_->generation = nextGeneration();
  return f;
}

bool DistanceField::isFree(const Vec3& p) const noexcept {
  int k[3];
  return impl_->voxelKey(p, k) && isFreeCell(impl_->cell(k[0], k[1], k[2]));
}

void DistanceField::freeVoxels(const std::int64_t lo[3], const std::int64_t n[3], std::uint8_t* out) const noexcept {
  const Impl& m = *impl_;
  auto key = [](std::int64_t v) { return v + internal::kKeyOffset; };
  auto inRange = [](std::int64_t k) { return k >= 0 && k <= 65535; };
  // Along x, the voxels [i0, i1) have keys in range; the rest are rock.
  const std::int64_t x0 = key(lo[0]);
  const std::int64_t i0 = std::clamp<std::int64_t>(-x0, 0, n[0]), i1 = std::clamp<std::int64_t>(65536 - x0, 0, n[0]);
  for (std::int64_t k = 0; k < n[2]; ++k) {
    const std::int64_t z = key(lo[2] + k);
    for (std::int64_t j = 0; j < n[1]; ++j) {
      const std::int64_t y = key(lo[1] + j);
      std::uint8_t* row = out + std::size_t(n[0] * (j + n[1] * k));
      if (!inRange(y) || !inRange(z) || i0 >= i1) {
        std::fill(row, row + n[0], std::uint8_t{0});
        continue;
      }
      std::fill(row, row + i0, std::uint8_t{0});
      std::fill(row + i1, row + n[0], std::uint8_t{0});
      m.forRowRuns(int(x0 + i0), int(x0 + i1 - 1), int(y), int(z), [row, x0](int x, const Cell* cells, int run) {
        for (int q = 0; q < run; ++q) row[x - x0 + q] = isFreeCell(cells[q]) ? 1 : 0;
      });
    }
  }
}

Vec3 DistanceField::nearestRockVoxel(const Vec3& p) const noexcept {
  const double res = impl_->res;
  int k[3];
  if (!impl_->voxelKey(p, k)) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  const Cell c = impl_->cell(k[0], k[1], k[2]);
  if (!isFreeCell(c)) return {centreOf(k[0], res), centreOf(k[1], res), centreOf(k[2], res)};
  if (!hasSite(c)) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  const std::uint64_t s = impl_->siteOf(c, k[0], k[1], k[2]);
  return {centreOf(keyCoord(s, 0), res), centreOf(keyCoord(s, 1), res), centreOf(keyCoord(s, 2), res)};
}

double DistanceField::voxelClearance(const Vec3& p) const noexcept {
  int k[3];
  if (!impl_->voxelKey(p, k)) return 0.0;
  const double d2 = impl_->storedClearance2(k[0], k[1], k[2]);
  return d2 < std::numeric_limits<double>::infinity() ? impl_->res * std::sqrt(d2) : impl_->res;
}

// The 8 cells around `base` (base + {0,1}^3, x fastest). False when they all lie in one tile of a
// block off the index: all rock, cells left unset.
[[gnu::always_inline]] inline bool DistanceField::Impl::gather8(const int base[3], Cell cells[8]) const {
  if ((base[0] & kTileMask) != kTileMask && (base[1] & kTileMask) != kTileMask &&
      (base[2] & kTileMask) != kTileMask) {
    // All 8 in one tile: one index read, one region read, 8 independent loads.
    const std::int32_t r = blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits, base[2] >> kBlockBits);
    if (r < 0) return false;  // the whole neighbourhood, p's voxel included, is rock
    const std::int32_t t = regions[std::size_t(r)][std::size_t(subIndex(base[0], base[1], base[2]))];
    const Cell* tile = tiles[std::size_t(t)].data() + localIndex(base[0], base[1], base[2]);
    constexpr int kDy = kTileSize, kDz = kTileSize * kTileSize;
    cells[0] = tile[0];         cells[1] = tile[1];
    cells[2] = tile[kDy];       cells[3] = tile[kDy + 1];
    cells[4] = tile[kDz];       cells[5] = tile[kDz + 1];
    cells[6] = tile[kDz + kDy]; cells[7] = tile[kDz + kDy + 1];
  } else {
    // Across tiles (tiles are small: the commoner case), perhaps across blocks. Each axis's two
    // voxel rows give a tile slot and a cell slot (and across blocks an index stride), so the 8
    // loads neither wait on each other nor branch but where a block lies off the index or holds
    // no free space.
    int sub[3][2], loc[3][2];
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < 2; ++i) {
        const int v = base[a] + i;
        sub[a][i] = ((v >> kTileBits) & kSubMask) << (a * kSubBits);
        loc[a][i] = (v & kTileMask) << (a * kTileBits);
      }
    const Tile* tl = tiles.data();
    if ((base[0] & kBlockMask) != kBlockMask && (base[1] & kBlockMask) != kBlockMask &&
        (base[2] & kBlockMask) != kBlockMask) {
      // Within one block (most of them): one index read, one region, the 8 loads written out
      // (the loop below, with its per-corner block tests and index reads, is 50 instructions a
      // corner).
      const std::int32_t r = blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits, base[2] >> kBlockBits);
      if (r < 0) return false;
      const std::int32_t* region = regions[std::size_t(r)].data();
#pragma GCC unroll 8
      for (int c = 0; c < 8; ++c) {
        const int i = c & 1, j = (c >> 1) & 1, k = c >> 2;
        cells[c] = tl[region[sub[0][i] | sub[1][j] | sub[2][k]]][std::size_t(loc[0][i] | loc[1][j] | loc[2][k])];
      }
    } else {
      const std::size_t stride[3] = {1, std::size_t(bdim[0]), std::size_t(bdim[0]) * std::size_t(bdim[1])};
      std::size_t off[3][2];
      bool inside[3][2];
      for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 2; ++i) {
          const int b = ((base[a] + i) >> kBlockBits) - bmin[a];
          inside[a][i] = unsigned(b) < unsigned(bdim[a]);
          off[a][i] = std::size_t(unsigned(b)) * stride[a];
        }
      const std::int32_t* ix = index.data();
      const Region* rg = regions.data();
#pragma GCC unroll 8
      for (int c = 0; c < 8; ++c) {
        const int i = c & 1, j = (c >> 1) & 1, k = c >> 2;
        const std::int32_t r =
            inside[0][i] && inside[1][j] && inside[2][k] ? ix[off[0][i] + off[1][j] + off[2][k]] : -1;
        const std::int32_t t = r < 0 ? kRockTile : rg[r][std::size_t(sub[0][i] | sub[1][j] | sub[2][k])];
        cells[c] = tl[t][std::size_t(loc[0][i] | loc[1][j] | loc[2][k])];
      }
    }
  }
  return true;
}

[[gnu::always_inline]] inline DistanceSample DistanceField::sample(const Vec3& p, bool full,
                                                                   DistanceReadCache* cache) const noexcept {
  // Plain scalars on purpose: this runs in every planner's inner loop (see tests/bench).
  DistanceSample out;
  out.nearest = p;
  const Impl& m = *impl_;
  const double px = p.x(), py = p.y(), pz = p.z();
  const double lim = 32767.0 * m.res;  // beyond: keys 0 or 65535, rock; NaN fails the test too
  if (!(std::abs(px) <= lim && std::abs(py) <= lim && std::abs(pz) <= lim)) return out;
  // p in voxel units; the 8 voxels whose centres surround p start at `base`. Their nearest rock
  // voxels contain p's nearest one in all but contrived cases (tests: within half a voxel).
  const double ux = px * m.inv, uy = py * m.inv, uz = pz * m.inv;
  const int base[3] = {internal::floorToInt(ux - 0.5) + internal::kKeyOffset,
                       internal::floorToInt(uy - 0.5) + internal::kKeyOffset,
                       internal::floorToInt(uz - 0.5) + internal::kKeyOffset};
  Cell cells[8];
  if (cache == nullptr) {
    if (!m.gather8(base, cells)) return out;
  } else {
    if (cache->generation_ != m.generation) cache->reset(m.generation);
    // A multiplicative hash of the base key: a segment's bases, neighbours in a line, spread
    // over the slots instead of wrapping onto a few as low key bits would.
    const std::uint32_t h = (std::uint32_t(base[0]) * 0x9E3779B1u + std::uint32_t(base[1]) * 0x85EBCA77u +
                             std::uint32_t(base[2]) * 0xC2B2AE3Du) >> (32 - DistanceReadCache::kSlotBits);
    DistanceReadCache::Slot& slot = cache->slots_[h];
    if (slot.key[0] == base[0] && slot.key[1] == base[1] && slot.key[2] == base[2]) {
      ++cache->hits_;
      std::memcpy(cells, slot.cells, sizeof cells);
    } else {
      ++cache->misses_;
      if (!m.gather8(base, cells)) std::fill(cells, cells + 8, Cell{0});
      std::memcpy(slot.key, base, sizeof slot.key);
      std::memcpy(slot.cells, cells, sizeof slot.cells);
    }
  }
  // Coordinates of p relative to the base voxel's centre, in voxels (each in [0, 1)).
  const double qx = ux - double(base[0] - internal::kKeyOffset) - 0.5;
  const double qy = uy - double(base[1] - internal::kKeyOffset) - 0.5;
  const double qz = uz - double(base[2] - internal::kKeyOffset) - 0.5;
  const int own_corner = (qx >= 0.5 ? 1 : 0) | (qy >= 0.5 ? 2 : 0) | (qz >= 0.5 ? 4 : 0);
  if (!isFreeCell(cells[own_corner])) return out;
  // Each corner's site relative to base: its offset plus the corner's own position (a rock
  // corner's offset is 0: it is its own site). Four corners to a vector (GCC's generic vectors:
  // SSE2 here, NEON on arm64), the same operations per corner as a scalar loop, so the answer is
  // bit for bit the one a plain loop gives.
  using V4i = std::int32_t __attribute__((vector_size(16)));
  using V4u = std::uint32_t __attribute__((vector_size(16)));
  using V2d = double __attribute__((vector_size(16)));
  using V2u = std::uint64_t __attribute__((vector_size(16)));
  alignas(16) int site[3][8];
  {
    // Built from scalars, not loaded as 16 bytes from the 4-byte stores just made (a load
    // wider than the stores it reads waits for them to retire).
    const V4u u[2] = {{cells[0], cells[1], cells[2], cells[3]}, {cells[4], cells[5], cells[6], cells[7]}};
    auto offset = [](V4u c, int axis) { return offsetBits<V4i>(c, axis); };  // cellOffset() of four
    const V4i cx = {0, 1, 0, 1}, cy = {0, 0, 1, 1};
    const V4i sx[2] = {offset(u[0], 0) + cx, offset(u[1], 0) + cx};
    const V4i sy[2] = {offset(u[0], 1) + cy, offset(u[1], 1) + cy};
    const V4i sz[2] = {offset(u[0], 2), offset(u[1], 2) + 1};
    std::memcpy(site[0], sx, sizeof sx);
    std::memcpy(site[1], sy, sizeof sy);
    std::memcpy(site[2], sz, sizeof sz);
  }
  const Cell any = cells[0] | cells[1] | cells[2] | cells[3] | cells[4] | cells[5] | cells[6] | cells[7];
  if (any & kFarBit) m.resolveFar(cells, base, site);
  // Distance from p to each candidate site's cube, per corner max(|q - s| - 0.5, 0) on each
  // axis, summed as ((ex^2 + ey^2) + ez^2); then the first nearest.
  const double q[3] = {qx, qy, qz};
  alignas(16) double e[3][8];  // all 24 kept: recomputing the nearest corner's 3 after the choice measured slower
  alignas(16) double d2[8];
  // Two corners to a vector, their sites converted from the four sites' int vector.
  for (int h = 0; h < 4; ++h) {
    V2d ea[3];
    for (int a = 0; a < 3; ++a) {
      V4i si;
      std::memcpy(&si, &site[a][4 * (h >> 1)], sizeof si);
#if defined(__SSE2__)
      // GCC converts an int pair one by one; this is the one instruction for it.
      const __m128i pair = (h & 1) ? _mm_unpackhi_epi64(__m128i(si), __m128i(si)) : __m128i(si);
      const V2d sd = V2d(_mm_cvtepi32_pd(pair));
#else
      const V2d sd = (h & 1) ? V2d{double(si[2]), double(si[3])} : V2d{double(si[0]), double(si[1])};
#endif
      const V2d t = q[a] - sd;
      const V2d mag = V2d(V2u(t) & ~(std::uint64_t{1} << 63)) - 0.5;  // fabs, then - 0.5
      ea[a] = mag < 0.0 ? V2d{0.0, 0.0} : mag;                         // std::max(mag, 0.0)
      std::memcpy(&e[a][2 * h], &ea[a], sizeof ea[a]);
    }
    const V2d sum = (ea[0] * ea[0] + ea[1] * ea[1]) + ea[2] * ea[2];
    std::memcpy(&d2[2 * h], &sum, sizeof sum);
  }
  // A free corner without a site knows no rock: it offers none.
  for (int c = 0; c < 8; ++c)
    if ((cells[c] & (kFreeBit | kSiteBit)) == kFreeBit) d2[c] = std::numeric_limits<double>::infinity();
  // The first nearest corner when the gradient is wanted; the distance alone needs only the least
  // value, taken four and two to a vector.
  int bc = 0;
  double best;
  if (full) {
    for (int c = 1; c < 8; ++c) bc = d2[c] < d2[bc] ? c : bc;
    best = d2[bc];
  } else {
    V2d v[4];
    std::memcpy(v, d2, sizeof v);
    const V2d a = v[0] < v[1] ? v[0] : v[1], b = v[2] < v[3] ? v[2] : v[3], c = a < b ? a : b;
    best = c[0] < c[1] ? c[0] : c[1];
  }
  if (!(best < std::numeric_limits<double>::infinity())) return out;  // no rock known
  out.in_rock = false;
  out.distance = std::sqrt(best) * m.res;
  if (!full) return out;
  const double bx = std::copysign(e[0][bc], qx - double(site[0][bc]));
  const double by = std::copysign(e[1][bc], qy - double(site[1][bc]));
  const double bz = std::copysign(e[2][bc], qz - double(site[2][bc]));
  const double dx = bx * m.res, dy = by * m.res, dz = bz * m.res;
  out.nearest = Vec3(px - dx, py - dy, pz - dz);
  if (out.distance > 0) {
    const double r = 1.0 / out.distance;
    out.gradient = Vec3(dx * r, dy * r, dz * r);
  }
  return out;
}

DistanceSample DistanceField::query(const Vec3& p) const noexcept { return sample(p, true, nullptr); }
double DistanceField::distance(const Vec3& p) const noexcept { return sample(p, false, nullptr).distance; }
double DistanceField::distance(const Vec3& p, DistanceReadCache& cache) const noexcept {
  return sample(p, false, &cache).distance;
}

DistanceReadCache::DistanceReadCache() : slots_(new Slot[std::size_t{1} << kSlotBits]) { reset(0); }

void DistanceReadCache::reset(std::uint64_t generation) noexcept {
  // Keys beyond the key range (they are 16-bit) name no base.
  for (std::size_t i = 0; i < (std::size_t{1} << kSlotBits); ++i) slots_[i].key[0] = -1;
  generation_ = generation;
}

Status DistanceField::update(const OccupancyMap& map, const Aabb& changed) { return update(map, changed, nullptr); }

Status DistanceField::update(const OccupancyMap& map, const Aabb& changed, DistanceFieldUpdateReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  DistanceFieldUpdateReport local;
  DistanceFieldUpdateReport& rep = report ? *report : local;
  rep = DistanceFieldUpdateReport();
  auto finish = [&] { rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  Impl& m = *impl_;
  if (std::abs(map.resolution() - m.res) > 1e-12) return invalidArgument("distance field update: map resolution differs");
  m.generation = nextGeneration();  // before any voxel changes: readers' caches are stale from here
  if (changed.empty() || !allFinite(changed.min) || !allFinite(changed.max))
    return invalidArgument("distance field update: empty or non-finite window");
  BoxI w;
  double window_voxels = 1.0;
  for (int a = 0; a < 3; ++a) {
    // Clamp in floating point first: a key of a far coordinate does not fit an int.
    auto key = [&](double c) { return int(std::clamp(std::floor(c * m.inv), -32767.0, 32766.0)) + internal::kKeyOffset; };
    w.lo[a] = key(changed.min[a]);
    w.hi[a] = key(changed.max[a]);
    window_voxels *= double(w.hi[a] - w.lo[a] + 1);
  }
  // A window larger than the tiles themselves: rebuilding from the octree is cheaper, and bounded.
  if (window_voxels > std::max(4.0 * double(m.regions.size()) * kBlockVoxels, 1e6)) {
    StatusOr<DistanceField> fresh = build(map);
    if (!fresh.ok()) return fresh.status();
    *this = std::move(fresh).value();
    rep.full_rebuild = true;
    rep.voxels_recomputed = impl_->stats.blocks * std::uint64_t(kBlockVoxels);
    finish();
    return {};
  }
  // How far the change can reach, read before the window is re-read (see localGrow()).
  const int grow_max = int(std::floor(m.stats.max_distance_m / m.res + 1e-9));
  double near_d2 = 0.0;
  const int grow = m.localGrow(w, grow_max, near_d2);
  // Re-read the changed voxels; new free space outside the tiles gets tiles.
  std::vector<std::array<int, 3>> coords;
  std::vector<std::array<int, 3>> now_free;
  std::int64_t free_delta = 0;
  for (int z = w.lo[2]; z <= w.hi[2]; ++z)
    for (int y = w.lo[1]; y <= w.hi[1]; ++y)
      for (int x = w.lo[0]; x <= w.hi[0]; ++x) {
        const Vec3 c(centreOf(x, m.res), centreOf(y, m.res), centreOf(z, m.res));
        const bool was_free = isFreeCell(m.cell(x, y, z));
        if (map.isFree(c)) {
          now_free.push_back({x, y, z});
          coords.push_back({x >> kTileBits, y >> kTileBits, z >> kTileBits});
          free_delta += was_free ? 0 : 1;
        } else {
          m.setFree(x, y, z, false);
          free_delta -= was_free ? 1 : 0;
        }
      }
  std::sort(coords.begin(), coords.end());
  coords.erase(std::unique(coords.begin(), coords.end()), coords.end());
  ADIT_RETURN_IF_ERROR(m.allocate(coords));
  for (const auto& k : now_free) m.setFree(k[0], k[1], k[2], true);
  // Voxels whose nearest rock may change lie within `grow` of the window: a voxel p whose site s
  // stays chooses another only if a changed voxel c is as near (|p - c| <= |p - s|, ties
  // included: a pass along a line picks between equally near rock only on that line, so a
  // farther change cannot reach p through it), and a voxel whose site was freed had it in the
  // window. Both distances are centre to centre, as max_distance_m is; the map's largest
  // clearance bounds them everywhere, the clearances around the window (localGrow) here.
  BoxI write;
  for (int a = 0; a < 3; ++a) { write.lo[a] = std::max(0, w.lo[a] - grow); write.hi[a] = std::min(65535, w.hi[a] + grow); }
  // The dense copy must hold each written voxel's nearest rock: checked below (worst <= margin),
  // and grown until it does. Around the window the clearances read before the change are known
  // (a freed site can only lengthen them, which the check catches).
  int margin = grow + 1;
  if (near_d2 < std::numeric_limits<double>::infinity())
    margin = std::max(grow, int(std::ceil(std::sqrt(near_d2) - 1e-9))) + 1;
  double worst = 0;
  for (;;) {
    BoxI r;
    bool whole = true;
    bool empty = false;
    for (int a = 0; a < 3; ++a) {
      const int glo = std::max(0, (m.bmin[a] << kBlockBits) - 1);
      const int ghi = std::min(65535, (m.bmin[a] + m.bdim[a]) << kBlockBits);
      r.lo[a] = std::max(write.lo[a] - margin, glo);
      r.hi[a] = std::min(write.hi[a] + margin, ghi);
      whole = whole && r.lo[a] == glo && r.hi[a] == ghi;
      empty = empty || r.lo[a] > r.hi[a];
    }
    if (empty) break;  // the window lies beyond every tile: all rock, nothing to recompute
    const double volume = double(r.hi[0] - r.lo[0] + 1) * double(r.hi[1] - r.lo[1] + 1) * double(r.hi[2] - r.lo[2] + 1);
    if (volume > 2e8) {  // the window grew to most of a large map: a full pass is cheaper
      m.transformAll({});
      rep.full_transform = true;
      rep.voxels_recomputed = (m.tiles.size() - 1) * std::uint64_t(kTileVoxels);
      break;
    }
    worst = m.transformBox(r, write);
    rep.recomputed = Aabb(Vec3(centreOf(write.lo[0], m.res), centreOf(write.lo[1], m.res), centreOf(write.lo[2], m.res)),
                          Vec3(centreOf(write.hi[0], m.res), centreOf(write.hi[1], m.res), centreOf(write.hi[2], m.res)));
    rep.voxels_recomputed = std::uint64_t(double(write.hi[0] - write.lo[0] + 1) * double(write.hi[1] - write.lo[1] + 1) *
                                          double(write.hi[2] - write.lo[2] + 1));
    if (worst <= margin || whole) break;
    margin *= 2;
  }
  if (m.far_overflow) return outOfRange("distance field update: the far table is full; rebuild the field");
  m.compactFar();
  // Incremental statistics: a full scan would cost as much as the update itself. The largest
  // clearance only grows here (it stays an upper bound, which is all update() needs of it).
  m.refreshMemoryStats();
  m.stats.free_voxels = std::uint64_t(std::int64_t(m.stats.free_voxels) + free_delta);
  if (std::isfinite(worst)) m.stats.max_distance_m = std::max(m.stats.max_distance_m, worst * m.res);
  finish();
  return {};
}

}  // namespace adit::map
