// SPDX-License-Identifier: BSD-3-Clause
// The distance field's tiles, two-level tile index, far table and statistics.
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "distance_field_impl.hpp"

namespace adit::map {
namespace dfield {

void adviseHugePages(void* data, std::size_t bytes) {
#ifdef MADV_HUGEPAGE
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t end = begin + bytes;
  const std::uintptr_t lo = (begin + kHuge - 1) & ~(kHuge - 1), hi = end & ~(kHuge - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

void adviseHugePages(std::vector<Tile>& tiles) { adviseHugePages(tiles.data(), tiles.capacity() * sizeof(Tile)); }

}  // namespace dfield

void DistanceField::Impl::resolveFar(const Cell cells[8], const int base[3], int s[3][8]) const {
  for (int c = 0; c < 8; ++c) {
    if (!isFarCell(cells[c])) continue;
    const std::uint64_t site = far[cells[c] & kFarIndexMask];
    for (int a = 0; a < 3; ++a) s[a][c] = keyCoord(site, a) - base[a];
  }
}

Status DistanceField::Impl::allocate(const std::vector<std::array<int, 3>>& tile_coords) {
  // Blocks created here are not in the index until it is rebuilt, once, at the end.
  std::map<std::array<int, 3>, std::int32_t> fresh;
  for (const auto& t : tile_coords) {
    const int x = t[0] << kTileBits, y = t[1] << kTileBits, z = t[2] << kTileBits;
    if (tileIndex(x, y, z) != kRockTile) continue;
    const std::array<int, 3> b = {x >> kBlockBits, y >> kBlockBits, z >> kBlockBits};
    std::int32_t r = blockIndex(b[0], b[1], b[2]);
    if (r < 0) {
      auto [it, inserted] = fresh.try_emplace(b, std::int32_t(regions.size()));
      if (inserted) appendRegion(b);
      r = it->second;
    }
    std::int32_t& slot = regions[std::size_t(r)][std::size_t(subIndex(x, y, z))];
    if (slot == kRockTile) slot = appendTile();
  }
  return fresh.empty() ? Status{} : rebuildIndex();
}

std::int32_t DistanceField::Impl::appendRegion(const std::array<int, 3>& c) {
  Region r;
  r.fill(kRockTile);
  regions.push_back(r);
  block_coords.push_back(c);
  return std::int32_t(regions.size() - 1);
}

std::int32_t DistanceField::Impl::appendTile() {
  if (tiles.size() == tiles.capacity()) {
    tiles.reserve(std::max<std::size_t>(64, 2 * tiles.capacity()));
    adviseHugePages(tiles);
  }
  tiles.emplace_back();
  return std::int32_t(tiles.size() - 1);
}

Status DistanceField::Impl::rebuildIndex() {
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) { lo[a] = std::numeric_limits<int>::max(); hi[a] = std::numeric_limits<int>::min(); }
  for (const auto& c : block_coords)
    for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], c[a]); hi[a] = std::max(hi[a], c[a]); }
  const double entries = double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
  if (entries > double(1 << 26)) {
    std::ostringstream os;
    os << "distance field: the free space spans " << (hi[0] - lo[0] + 1) << " x " << (hi[1] - lo[1] + 1) << " x "
       << (hi[2] - lo[2] + 1) << " tiles of " << kBlockSize << "^3 voxels; the tile index would need "
       << entries * 4 / double(1 << 20) << " MiB (limit 256 MiB): crop the map or use a coarser resolution";
    return outOfRange(os.str());
  }
  for (int a = 0; a < 3; ++a) { bmin[a] = lo[a]; bdim[a] = hi[a] - lo[a] + 1; }
  index.assign(std::size_t(bdim[0]) * std::size_t(bdim[1]) * std::size_t(bdim[2]), -1);
  for (std::size_t i = 0; i < block_coords.size(); ++i) {
    const auto& c = block_coords[i];
    const std::size_t at = (std::size_t(c[2] - bmin[2]) * std::size_t(bdim[1]) + std::size_t(c[1] - bmin[1])) *
                               std::size_t(bdim[0]) + std::size_t(c[0] - bmin[0]);
    if (index[at] < 0) index[at] = std::int32_t(i);
  }
  return {};
}

void DistanceField::Impl::compactFar() {
  if (far_unused < 4096 || 2 * far_unused < far.size()) return;
  std::vector<std::uint64_t> live;
  live.reserve(far.size() - std::min<std::size_t>(far.size(), far_unused));
  for (Tile& t : tiles)
    for (Cell& c : t)
      if (isFarCell(c)) {
        live.push_back(far[c & kFarIndexMask]);
        c = (c & ~kFarIndexMask) | Cell(live.size() - 1);
      }
  far = std::move(live);
  far_unused = 0;
}

void DistanceField::Impl::refreshMemoryStats() {
  stats.blocks = regions.size();
  stats.index_entries = index.size();
  stats.tiles = tiles.empty() ? 0 : tiles.size() - 1;  // not the shared rock tile
  stats.tile_edge_voxels = kTileSize;
  stats.far_sites = far.size();
  stats.memory_bytes = tiles.size() * sizeof(Tile) + regions.size() * sizeof(Region) +
                       index.size() * sizeof(std::int32_t) + block_coords.size() * sizeof(block_coords[0]) +
                       far.size() * sizeof(far[0]);
}

void DistanceField::Impl::refreshStats() {
  refreshMemoryStats();
  std::uint64_t free_count = 0;
  double max_d2 = 0;
  for (std::size_t r = 0; r < regions.size(); ++r) {
    const auto& b = block_coords[r];
    for (int j = 0; j < kTilesPerBlock; ++j) {
      const std::int32_t t = regions[r][std::size_t(j)];
      if (t == kRockTile) continue;
      const int x0 = (b[0] << kBlockBits) + ((j & kSubMask) << kTileBits);
      const int y0 = (b[1] << kBlockBits) + (((j >> kSubBits) & kSubMask) << kTileBits);
      const int z0 = (b[2] << kBlockBits) + ((j >> (2 * kSubBits)) << kTileBits);
      for (int l = 0; l < kTileVoxels; ++l) {
        const Cell c = tiles[std::size_t(t)][std::size_t(l)];
        if (!isFreeCell(c)) continue;
        ++free_count;
        if (!hasSite(c)) continue;
        const int x = x0 + (l & kTileMask), y = y0 + ((l >> kTileBits) & kTileMask), z = z0 + (l >> (2 * kTileBits));
        const std::uint64_t s = siteOf(c, x, y, z);
        const double dx = x - keyCoord(s, 0), dy = y - keyCoord(s, 1), dz = z - keyCoord(s, 2);
        max_d2 = std::max(max_d2, dx * dx + dy * dy + dz * dz);
      }
    }
  }
  stats.free_voxels = free_count;
  stats.max_distance_m = std::sqrt(max_d2) * res;
}

}  // namespace adit::map
