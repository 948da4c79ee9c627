// SPDX-License-Identifier: BSD-3-Clause
// The distance field's tiles, dense tile index and statistics.
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "distance_field_impl.hpp"

namespace adit::map {
namespace dfield {

void adviseHugePages(std::vector<Block>& blocks) {
#ifdef MADV_HUGEPAGE
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(blocks.data());
  const std::uintptr_t end = begin + blocks.capacity() * sizeof(Block);
  const std::uintptr_t lo = (begin + kHuge - 1) & ~(kHuge - 1), hi = end & ~(kHuge - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#else
  (void)blocks;
#endif
}

}  // namespace dfield


// Allocates (rock-initialised) tiles for the given distinct block coords and rebuilds the
// dense index over the union of old and new tiles.
Status DistanceField::Impl::allocate(const std::vector<std::array<int, 3>>& coords) {
  std::vector<std::array<int, 3>> fresh;
  for (const auto& c : coords)
    if (blockIndex(c[0], c[1], c[2]) < 0) fresh.push_back(c);
  if (fresh.empty()) return {};
  for (const auto& c : fresh) appendTile(c);
  return rebuildIndex();
}

// A new all-rock tile (value-initialised words are 0). Capacity grows geometrically, and the
// new range is advised onto huge pages.
Block& DistanceField::Impl::appendTile(const std::array<int, 3>& c) {
  if (blocks.size() == blocks.capacity()) {
    blocks.reserve(std::max<std::size_t>(64, 2 * blocks.capacity()));
    adviseHugePages(blocks);
  }
  block_coords.push_back(c);
  return blocks.emplace_back();
}

// The dense tile index over the bounding box of all tiles: 4 bytes per 16^3 voxels of the box
// (37 MB for 2 km x 1 km x 150 m at 0.2 m). Refused beyond 2^26 entries (256 MiB), which only
// free space scattered over kilometres at a fine resolution reaches.
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

void DistanceField::Impl::refreshMemoryStats() {
  stats.blocks = blocks.size();
  stats.index_entries = index.size();
  stats.memory_bytes = blocks.size() * sizeof(Block) + index.size() * sizeof(std::int32_t) +
                       block_coords.size() * sizeof(block_coords[0]);
}

void DistanceField::Impl::refreshStats() {
  refreshMemoryStats();
  std::uint64_t free_count = 0;
  double max_d2 = 0;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const auto& c = block_coords[i];
    for (int l = 0; l < kBlockVoxels; ++l) {
      const std::uint64_t w = blocks[i][std::size_t(l)];
      if (!isFreeWord(w)) continue;
      ++free_count;
      const int x = (c[0] << kBlockBits) + (l & kBlockMask), y = (c[1] << kBlockBits) + ((l >> kBlockBits) & kBlockMask),
                z = (c[2] << kBlockBits) + (l >> (2 * kBlockBits));
      const double dx = x - siteCoord(w, 0), dy = y - siteCoord(w, 1), dz = z - siteCoord(w, 2);
      max_d2 = std::max(max_d2, dx * dx + dy * dy + dz * dz);
    }
  }
  stats.free_voxels = free_count;
  stats.max_distance_m = std::sqrt(max_d2) * res;
}

}  // namespace adit::map
