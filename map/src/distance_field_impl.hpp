// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit_map: the distance field's storage, shared by its three sources —
// distance_field.cpp (build from the octree, queries, windowed update), distance_field_storage.cpp
// (tiles, the dense tile index, statistics) and distance_field_transform.cpp (the separable
// Euclidean feature transform). See distance_field.hpp for the contract.
#include <octomap/OcTree.h>

#include <array>
#include <cstdint>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "voxel_blocks.hpp"

namespace adit::map {
namespace dfield {

using internal::centreOf;
using internal::kBlockBits;
using internal::kBlockMask;
using internal::kBlockSize;
using internal::kBlockVoxels;
using internal::keyOf;

// A voxel word: for a free voxel, the key of its nearest rock voxel (16 bits per axis) plus two
// flags; a rock voxel is 0 and is its own site, so new tiles need no more than zero pages.
constexpr std::uint64_t kFreeBit = std::uint64_t{1} << 48;
constexpr std::uint64_t kSiteBit = std::uint64_t{1} << 49;
constexpr std::uint64_t kKeyMask = (std::uint64_t{1} << 48) - 1;

inline std::uint64_t packKey(int x, int y, int z) {
  return std::uint64_t(std::uint16_t(x)) | (std::uint64_t(std::uint16_t(y)) << 16) |
         (std::uint64_t(std::uint16_t(z)) << 32);
}
inline int siteCoord(std::uint64_t w, int axis) { return int((w >> (16 * axis)) & 0xFFFF); }
inline std::uint64_t rockWord(int x, int y, int z) { return packKey(x, y, z) | kSiteBit; }
inline bool isFreeWord(std::uint64_t w) { return w & kFreeBit; }
inline bool hasSite(std::uint64_t w) { return w & kSiteBit; }

using Block = std::array<std::uint64_t, kBlockVoxels>;
inline int localIndex(int x, int y, int z) {
  return (x & kBlockMask) | ((y & kBlockMask) << kBlockBits) | ((z & kBlockMask) << (2 * kBlockBits));
}

// Tiles are read at random by queries: 2 MiB pages spare most TLB misses.
void adviseHugePages(std::vector<Block>& blocks);

struct BoxI {
  int lo[3], hi[3];  // inclusive voxel keys
};

// A direct walk of the octree: several times faster than OctoMap's leaf_iterator, and it yields
// the key box of each leaf without going through coordinates. fn(lo, size, occupied).
template <class Fn>
void visitLeaves(const octomap::OcTree& tree, const octomap::OcTreeNode* node, int x, int y, int z, int size,
                 Fn& fn) {
  if (!tree.nodeHasChildren(node)) {
    const int lo[3] = {x, y, z};
    fn(lo, size, tree.isNodeOccupied(node));
    return;
  }
  const int h = size / 2;
  for (unsigned i = 0; i < 8; ++i)
    if (tree.nodeChildExists(node, i))
      visitLeaves(tree, tree.getNodeChild(node, i), x + int(i & 1u) * h, y + int((i >> 1) & 1u) * h,
                  z + int((i >> 2) & 1u) * h, h, fn);
}

template <class Fn>
void visitLeaves(const octomap::OcTree& tree, Fn&& fn) {
  if (tree.getRoot()) visitLeaves(tree, tree.getRoot(), 0, 0, 0, 1 << tree.getTreeDepth(), fn);
}

}  // namespace dfield

// A private header of three sources that all speak the tile vocabulary.
using namespace dfield;  // NOLINT(google-build-using-namespace)

struct DistanceField::Impl {
  double res = 0.1, inv = 10.0;
  int bmin[3] = {0, 0, 0};   // block grid origin (block coords)
  int bdim[3] = {0, 0, 0};   // block grid size
  std::vector<std::int32_t> index;  // dense, -1 = rock
  std::vector<Block> blocks;
  std::vector<std::array<int, 3>> block_coords;
  DistanceFieldStats stats;

  std::int32_t blockIndex(int bx, int by, int bz) const {
    const int x = bx - bmin[0], y = by - bmin[1], z = bz - bmin[2];
    if (unsigned(x) >= unsigned(bdim[0]) || unsigned(y) >= unsigned(bdim[1]) || unsigned(z) >= unsigned(bdim[2]))
      return -1;
    return index[(std::size_t(z) * std::size_t(bdim[1]) + std::size_t(y)) * std::size_t(bdim[0]) + std::size_t(x)];
  }
  // The 8 words around a tile edge: rare, kept out of line so that query() stays small.
  [[gnu::noinline, gnu::cold]] void gatherAcrossTiles(const int base[3], std::uint64_t words[8]) const {
    for (int c = 0; c < 8; ++c) words[c] = word(base[0] + (c & 1), base[1] + ((c >> 1) & 1), base[2] + (c >> 2));
  }
  // Key of the voxel holding p; false for NaN and beyond the key range (rock there).
  bool voxelKey(const Vec3& p, int k[3]) const {
    const double lim = 32767.0 * res;  // beyond: keys 0 or 65535
    for (int a = 0; a < 3; ++a) {
      if (!(std::abs(p[a]) <= lim)) return false;
      k[a] = keyOf(p[a], inv);
    }
    return true;
  }
  std::uint64_t word(int x, int y, int z) const {
    const std::int32_t b = blockIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
    return b < 0 ? 0 : blocks[std::size_t(b)][std::size_t(localIndex(x, y, z))];
  }

  void setFree(int x, int y, int z, bool free) {
    const std::int32_t b = blockIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
    if (b < 0) return;  // rock stays implicit
    blocks[std::size_t(b)][std::size_t(localIndex(x, y, z))] = free ? kFreeBit : 0;
  }

  // ---- tiles and statistics (distance_field_storage.cpp)
  // Allocates (rock-initialised) tiles for the given distinct block coords and rebuilds the
  // dense index over the union of old and new tiles.
  Status allocate(const std::vector<std::array<int, 3>>& coords);
  // A new all-rock tile (value-initialised words are 0). Capacity grows geometrically, and the
  // new range is advised onto huge pages.
  Block& appendTile(const std::array<int, 3>& c);
  // The dense tile index over the bounding box of all tiles: 4 bytes per 16^3 voxels of the box
  // (37 MB for 2 km x 1 km x 150 m at 0.2 m). Refused beyond 2^26 entries (256 MiB), which only
  // free space scattered over kilometres at a fine resolution reaches.
  Status rebuildIndex();
  void refreshMemoryStats();
  void refreshStats();

  // ---- the transform (distance_field_transform.cpp)
  // Full transform in place, over the allocated tiles only: along each axis, the tiles are
  // grouped in lines; gaps between tiles (and the ends) are rock, of which only the two voxels
  // bounding each gap can be nearest for anything outside it.
  void transformAll(const ProgressFn& progress);
  // Transform over a dense copy of box `r` (outside it: no sites), writing back the free voxels
  // of `write`. Returns the largest centre-to-centre distance (voxels) found in `write`, or
  // infinity if some free voxel there saw no rock inside `r`.
  double transformBox(const BoxI& r, BoxI write);
};

}  // namespace adit::map
