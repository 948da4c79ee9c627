// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit_map: the distance field's storage, shared by its three sources —
// distance_field.cpp (build from the octree, queries, windowed update), distance_field_storage.cpp
// (tiles, the two-level tile index, statistics) and distance_field_transform.cpp (the separable
// Euclidean feature transform). See distance_field.hpp for the contract.
#include <octomap/OcTree.h>

#include <algorithm>
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

// Storage: 16^3 blocks (the dense top-level index, one entry per block of the bounding box) are
// split into 4^3 tiles, and only tiles that hold a free voxel exist. On the district 16^3 tiles
// are 32 % free, 8^3 tiles 51 %, 4^3 tiles 73 %: with 4-byte cells, 4^3 tiles come to 6 bytes per
// free voxel with the index (8^3 tiles to 8.2), a quarter of the 16^3 tiles of 8-byte words.
constexpr int kTileBits = internal::kFieldTileBits;
constexpr int kTileSize = 1 << kTileBits;
constexpr int kTileMask = kTileSize - 1;
constexpr int kTileVoxels = kTileSize * kTileSize * kTileSize;
constexpr int kSubBits = kBlockBits - kTileBits;  // tiles per block edge: 1 << kSubBits
constexpr int kSubMask = (1 << kSubBits) - 1;
constexpr int kTilesPerBlock = 1 << (3 * kSubBits);

// A cell: 0 is rock (its own nearest rock voxel), so new tiles need no more than zero pages. A
// free cell holds the offset from the voxel to its nearest rock voxel, 9 bits per axis: a
// roadway's clearance is a few metres, far inside +-255 voxels. A site farther than that on some
// axis (a wide chamber at a fine resolution, unknown space taken as free) is kept exactly in the
// far table, whose index the cell then holds.
using Cell = std::uint32_t;
constexpr Cell kFreeBit = Cell{1} << 31;
constexpr Cell kSiteBit = Cell{1} << 30;
constexpr Cell kFarBit = Cell{1} << 29;
constexpr int kOffsetBits = 9;
constexpr int kOffsetMax = (1 << (kOffsetBits - 1)) - 1;
constexpr Cell kOffsetField = (Cell{1} << kOffsetBits) - 1;
constexpr Cell kFarIndexMask = kFarBit - 1;
constexpr std::uint64_t kMaxFarSites = kFarIndexMask + std::uint64_t{1};

inline bool isFreeCell(Cell c) { return c & kFreeBit; }
inline bool hasSite(Cell c) { return c & kSiteBit; }
inline bool isFarCell(Cell c) { return c & kFarBit; }
// The axis's 9 offset bits moved to the top, then shifted down with their sign: for one cell
// (S = std::int32_t) or, in query(), for a vector of cells (S its signed vector type).
template <class S, class U>
S offsetBits(U c, int axis) {
  return S(c << (32 - kOffsetBits * (axis + 1))) >> (32 - kOffsetBits);
}
// Offset on `axis` of a near cell (0 for rock), sign-extended from its 9 bits.
inline int cellOffset(Cell c, int axis) { return offsetBits<std::int32_t>(c, axis); }

// A site as a whole key (16 bits per axis): what the far table and the transform hold.
inline std::uint64_t packKey(int x, int y, int z) {
  return std::uint64_t(std::uint16_t(x)) | (std::uint64_t(std::uint16_t(y)) << 16) |
         (std::uint64_t(std::uint16_t(z)) << 32);
}
inline int keyCoord(std::uint64_t k, int axis) { return int((k >> (16 * axis)) & 0xFFFF); }

using Tile = std::array<Cell, kTileVoxels>;
// A block's tiles. Tile 0 is all rock and shared by every rock tile of every region, so that a
// lookup within a region never branches; it is never written.
using Region = std::array<std::int32_t, kTilesPerBlock>;
constexpr std::int32_t kRockTile = 0;

inline int localIndex(int x, int y, int z) {
  return (x & kTileMask) | ((y & kTileMask) << kTileBits) | ((z & kTileMask) << (2 * kTileBits));
}
inline int subIndex(int x, int y, int z) {
  return ((x >> kTileBits) & kSubMask) | (((y >> kTileBits) & kSubMask) << kSubBits) |
         (((z >> kTileBits) & kSubMask) << (2 * kSubBits));
}

// Tiles are read at random by queries: 2 MiB pages spare most TLB misses. The first form
// advises the 2 MiB-aligned part of any buffer, before it is first written: a page fault costs
// about 10 us on these virtual machines, and 2 MiB pages take 512 times fewer.
void adviseHugePages(void* data, std::size_t bytes);
void adviseHugePages(std::vector<Tile>& tiles);

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
  std::vector<std::int32_t> index;  // dense over the blocks, -1 = rock; else a region
  std::vector<Region> regions;      // one per block that holds free space
  std::vector<std::array<int, 3>> block_coords;  // of each region
  std::vector<Tile> tiles;
  std::vector<std::uint64_t> far;   // sites (packed keys) of the cells flagged kFarBit
  std::uint64_t far_unused = 0;     // entries no cell names any more (update() rewrote them)
  bool far_overflow = false;        // a site found no room in the far table
  int near_limit = kOffsetMax;      // lowered by buildWithNearLimitForTesting() only
  DistanceFieldStats stats;
  std::uint64_t generation = 0;     // DistanceField::generation()

  std::int32_t blockIndex(int bx, int by, int bz) const {
    const int x = bx - bmin[0], y = by - bmin[1], z = bz - bmin[2];
    if (unsigned(x) >= unsigned(bdim[0]) || unsigned(y) >= unsigned(bdim[1]) || unsigned(z) >= unsigned(bdim[2]))
      return -1;
    return index[(std::size_t(z) * std::size_t(bdim[1]) + std::size_t(y)) * std::size_t(bdim[0]) + std::size_t(x)];
  }
  // kRockTile where there is no tile.
  std::int32_t tileIndex(int x, int y, int z) const {
    const std::int32_t r = blockIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
    return r < 0 ? kRockTile : regions[std::size_t(r)][std::size_t(subIndex(x, y, z))];
  }
  // The 8 cells of sample() (distance_field.cpp).
  [[gnu::always_inline]] inline bool gather8(const int base[3], Cell cells[8]) const;
  // Sites of the far cells among the 8 (relative to base); rare, out of line.
  [[gnu::noinline, gnu::cold]] void resolveFar(const Cell cells[8], const int base[3], int s[3][8]) const;
  // Key of the voxel holding p; false for NaN and beyond the key range (rock there).
  bool voxelKey(const Vec3& p, int k[3]) const {
    const double lim = 32767.0 * res;  // beyond: keys 0 or 65535
    for (int a = 0; a < 3; ++a) {
      if (!(std::abs(p[a]) <= lim)) return false;
      k[a] = keyOf(p[a], inv);
    }
    return true;
  }
  Cell cell(int x, int y, int z) const {
    return tiles[std::size_t(tileIndex(x, y, z))][std::size_t(localIndex(x, y, z))];
  }
  // fn(x, cells, run) over the voxels x0..x1 (keys) of row (y, z), a tile's row at a time: cells
  // points at voxel x's cell and the next run - 1 voxels' follow it. One tile lookup a run.
  template <class Fn>
  void forRowRuns(int x0, int x1, int y, int z, Fn&& fn) const {
    for (int x = x0; x <= x1;) {
      const int run = std::min(kTileSize - (x & kTileMask), x1 - x + 1);
      fn(x, tiles[std::size_t(tileIndex(x, y, z))].data() + localIndex(x, y, z), run);
      x += run;
    }
  }
  // The nearest rock voxel of a free cell with a site at (x, y, z), as a packed key.
  std::uint64_t siteOf(Cell c, int x, int y, int z) const {
    if (isFarCell(c)) return far[c & kFarIndexMask];
    return packKey(x + cellOffset(c, 0), y + cellOffset(c, 1), z + cellOffset(c, 2));
  }
  // The cell of free voxel (x, y, z) whose nearest rock voxel is `site`; sites out of the
  // offset range go to the far table.
  Cell encodeSite(int x, int y, int z, std::uint64_t site) {
    const int d[3] = {keyCoord(site, 0) - x, keyCoord(site, 1) - y, keyCoord(site, 2) - z};
    auto fits = [this](int v) { return std::abs(v) <= near_limit; };
    if (fits(d[0]) && fits(d[1]) && fits(d[2]))
      return kFreeBit | kSiteBit | (Cell(d[0]) & kOffsetField) | ((Cell(d[1]) & kOffsetField) << kOffsetBits) |
             ((Cell(d[2]) & kOffsetField) << (2 * kOffsetBits));
    if (far.size() >= kMaxFarSites) {  // 4 GiB of far sites: build() and update() refuse the map
      far_overflow = true;
      return kFreeBit;
    }
    far.push_back(site);
    return kFreeBit | kSiteBit | kFarBit | Cell(far.size() - 1);
  }
  // A cell about to be overwritten: its far entry, if any, becomes unused.
  void retire(Cell c) { far_unused += isFarCell(c) ? 1 : 0; }

  void setFree(int x, int y, int z, bool free) {
    const std::int32_t t = tileIndex(x, y, z);
    if (t == kRockTile) return;  // rock stays implicit
    Cell& c = tiles[std::size_t(t)][std::size_t(localIndex(x, y, z))];
    retire(c);
    c = free ? kFreeBit : 0;
  }

  // Squared centre-to-centre distance (voxels^2) from voxel (x, y, z) to its stored nearest rock
  // voxel: 0 for rock, infinity for a free voxel whose site is not known.
  double storedClearance2(int x, int y, int z) const;
  // How far beyond the changed box w update() must rewrite voxels, read from the field before w
  // is re-read: at most grow_max (the map's largest clearance); `max_d2` gets the largest squared
  // clearance within the box grown by the answer, or infinity when it is grow_max.
  int localGrow(const BoxI& w, int grow_max, double& max_d2) const;

  // ---- tiles and statistics (distance_field_storage.cpp)
  // Allocates (rock-initialised) tiles for the given distinct tile coords (key >> kTileBits),
  // with regions for blocks that had none, and rebuilds the top-level index if blocks were added.
  Status allocate(const std::vector<std::array<int, 3>>& tile_coords);
  // A new region (all tiles rock) for block c; not in the index until rebuildIndex().
  std::int32_t appendRegion(const std::array<int, 3>& c);
  // A new all-rock tile (value-initialised cells are 0). Capacity grows geometrically, and the
  // new range is advised onto huge pages.
  std::int32_t appendTile();
  // The dense block index over the bounding box of all blocks: 4 bytes per 16^3 voxels of the
  // box (37 MB for 2 km x 1 km x 150 m at 0.2 m). Refused beyond 2^26 entries (256 MiB), which
  // only free space scattered over kilometres at a fine resolution reaches.
  Status rebuildIndex();
  // Drops far-table entries no cell names once they outnumber the live ones.
  void compactFar();
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
