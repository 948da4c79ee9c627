// SPDX-License-Identifier: BSD-3-Clause
// Sparse exact Euclidean feature transform. See distance_field.hpp for the contract.
#include "adit/map/distance_field.hpp"

#include <octomap/OcTree.h>
#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>

#include "voxel_blocks.hpp"

namespace adit::map {

namespace {

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

// One line of the separable transform: candidates (position along the line, squared distance
// already accumulated over the earlier axes, site word) in increasing position; for every query
// position (increasing) the candidate minimising (q - p)^2 + f. Felzenszwalb & Huttenlocher 2012.
class LineSolver {
 public:
  void clear() { pos_.clear(); f_.clear(); site_.clear(); all_zero_ = true; }
  void add(int p, double f, std::uint64_t site) {
    pos_.push_back(p);
    f_.push_back(f);
    site_.push_back(site);
    all_zero_ = all_zero_ && f == 0.0;
  }
  bool empty() const { return pos_.empty(); }

  void prepare() {
    k_ = 0;
    // Only rock on the line (the first pass): the nearest candidate by position, no envelope.
    if (all_zero_) return;
    const std::size_t n = pos_.size();
    v_.resize(n);
    z_.resize(n + 1);
    int k = 0;
    v_[0] = 0;
    z_[0] = -std::numeric_limits<double>::infinity();
    z_[1] = std::numeric_limits<double>::infinity();
    for (std::size_t q = 1; q < n; ++q) {
      double s;
      for (;;) {
        const std::size_t r = v_[std::size_t(k)];
        s = ((f_[q] + double(pos_[q]) * pos_[q]) - (f_[r] + double(pos_[r]) * pos_[r])) /
            (2.0 * double(pos_[q] - pos_[r]));
        if (s <= z_[std::size_t(k)]) { --k; continue; }  // z_[0] = -inf ends this
        break;
      }
      ++k;
      v_[std::size_t(k)] = q;
      z_[std::size_t(k)] = s;
      z_[std::size_t(k) + 1] = std::numeric_limits<double>::infinity();
    }
    k_ = 0;
  }
  // Queries must come in increasing position after prepare().
  std::uint64_t solve(int q) {
    if (all_zero_) {
      const std::size_t n = pos_.size();
      std::size_t k = std::size_t(k_);
      while (k + 1 < n && pos_[k + 1] <= q) ++k;
      if (k + 1 < n && (pos_[k] > q || pos_[k + 1] - q < q - pos_[k])) {
        k_ = int(k);
        return site_[pos_[k] > q ? k : k + 1];
      }
      k_ = int(k);
      return site_[k];
    }
    while (z_[std::size_t(k_) + 1] < double(q)) ++k_;
    return site_[v_[std::size_t(k_)]];
  }

 private:
  std::vector<int> pos_;
  std::vector<double> f_;
  std::vector<std::uint64_t> site_;
  std::vector<std::size_t> v_;
  std::vector<double> z_;
  int k_ = 0;
  bool all_zero_ = true;
};

// Squared distance from voxel `key` to the site in `w`, over the axes before `axis` (the axes a
// previous pass has already resolved; the other coordinates of the site equal the voxel's).
inline double partialF(const int key[3], std::uint64_t w, int axis) {
  double f = 0;
  for (int a = 0; a < axis; ++a) {
    const double d = key[a] - siteCoord(w, a);
    f += d * d;
  }
  return f;
}

// Tiles are read at random by queries: 2 MiB pages spare most TLB misses (Linux THP in
// "madvise" mode; elsewhere the advice is ignored).
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

}  // namespace

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

  // Allocates (rock-initialised) tiles for the given distinct block coords and rebuilds the
  // dense index over the union of old and new tiles.
  Status allocate(const std::vector<std::array<int, 3>>& coords) {
    std::vector<std::array<int, 3>> fresh;
    for (const auto& c : coords)
      if (blockIndex(c[0], c[1], c[2]) < 0) fresh.push_back(c);
    if (fresh.empty()) return {};
    for (const auto& c : fresh) appendTile(c);
    return rebuildIndex();
  }

  // A new all-rock tile (value-initialised words are 0). Capacity grows geometrically, and the
  // new range is advised onto huge pages.
  Block& appendTile(const std::array<int, 3>& c) {
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
  Status rebuildIndex() {
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

  void setFree(int x, int y, int z, bool free) {
    const std::int32_t b = blockIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
    if (b < 0) return;  // rock stays implicit
    blocks[std::size_t(b)][std::size_t(localIndex(x, y, z))] = free ? kFreeBit : 0;
  }

  // Full transform in place, over the allocated tiles only: along each axis, the tiles are
  // grouped in lines; gaps between tiles (and the ends) are rock, of which only the two voxels
  // bounding each gap can be nearest for anything outside it.
  void transformAll(const ProgressFn& progress) {
    for (Block& b : blocks)
      for (std::uint64_t& w : b)
        if (isFreeWord(w)) w = kFreeBit;  // the first pass must see rock voxels only
    LineSolver solver;
    std::vector<std::pair<int, std::uint64_t*>> queries;
    for (int axis = 0; axis < 3; ++axis) {
      const int b1 = (axis + 1) % 3, b2 = (axis + 2) % 3;
      // Tiles sorted by (other two block coords, own coord) form the lines.
      std::vector<std::uint32_t> order(blocks.size());
      for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
      std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        const auto& ca = block_coords[a];
        const auto& cb = block_coords[b];
        if (ca[b2] != cb[b2]) return ca[b2] < cb[b2];
        if (ca[b1] != cb[b1]) return ca[b1] < cb[b1];
        return ca[axis] < cb[axis];
      });
      std::size_t start = 0;
      while (start < order.size()) {
        std::size_t end = start + 1;
        while (end < order.size() && block_coords[order[end]][b1] == block_coords[order[start]][b1] &&
               block_coords[order[end]][b2] == block_coords[order[start]][b2])
          ++end;
        for (int u = 0; u < kBlockSize; ++u)
          for (int v = 0; v < kBlockSize; ++v) {
            int key[3];
            key[b1] = (block_coords[order[start]][b1] << kBlockBits) + u;
            key[b2] = (block_coords[order[start]][b2] << kBlockBits) + v;
            solver.clear();
            queries.clear();
            auto addRock = [&](int p) {
              // Keys 0 and 65535 are always rock (see build()), so nothing beyond them is needed.
              if (p < 0 || p > 65535) return;
              key[axis] = p;
              solver.add(p, 0.0, rockWord(key[0], key[1], key[2]));
            };
            int prev_end = std::numeric_limits<int>::min();
            for (std::size_t i = start; i < end; ++i) {
              const int first = block_coords[order[i]][axis] << kBlockBits;
              if (first != prev_end + 1) {
                if (prev_end != std::numeric_limits<int>::min()) addRock(prev_end + 1);
                if (prev_end == std::numeric_limits<int>::min() || first - 1 > prev_end + 1) addRock(first - 1);
              }
              Block& blk = blocks[order[i]];
              for (int p = first; p < first + kBlockSize; ++p) {
                key[axis] = p;
                std::uint64_t& w = blk[std::size_t(localIndex(key[0], key[1], key[2]))];
                if (!isFreeWord(w)) {
                  solver.add(p, 0.0, rockWord(key[0], key[1], key[2]));
                } else {
                  if (hasSite(w)) solver.add(p, partialF(key, w, axis), w & kKeyMask);
                  queries.emplace_back(p, &w);
                }
              }
              prev_end = first + kBlockSize - 1;
            }
            addRock(prev_end + 1);
            if (queries.empty()) continue;
            solver.prepare();
            for (auto& [p, w] : queries) *w = kFreeBit | kSiteBit | solver.solve(p);
          }
        start = end;
      }
      if (progress) progress("distance field", double(axis + 1) / 3.0);
    }
  }

  // Transform over a dense copy of box `r` (outside it: no sites), writing back the free voxels
  // of `write`. Returns the largest centre-to-centre distance (voxels) found in `write`, or
  // infinity if some free voxel there saw no rock inside `r`.
  double transformBox(const BoxI& r, BoxI write) {
    for (int a = 0; a < 3; ++a) {  // nothing outside the tiles to write
      write.lo[a] = std::max(write.lo[a], r.lo[a]);
      write.hi[a] = std::min(write.hi[a], r.hi[a]);
    }
    const int n[3] = {r.hi[0] - r.lo[0] + 1, r.hi[1] - r.lo[1] + 1, r.hi[2] - r.lo[2] + 1};
    std::vector<std::uint64_t> grid(static_cast<std::size_t>(n[0]) * std::size_t(n[1]) * std::size_t(n[2]));
    auto at = [&](int x, int y, int z) -> std::uint64_t& {
      return grid[(std::size_t(z - r.lo[2]) * std::size_t(n[1]) + std::size_t(y - r.lo[1])) * std::size_t(n[0]) +
                  std::size_t(x - r.lo[0])];
    };
    for (int z = r.lo[2]; z <= r.hi[2]; ++z)
      for (int y = r.lo[1]; y <= r.hi[1]; ++y)
        for (int x = r.lo[0]; x <= r.hi[0]; ++x) {
          const std::uint64_t w = word(x, y, z);
          at(x, y, z) = isFreeWord(w) ? kFreeBit : 0;
        }
    LineSolver solver;
    std::vector<std::pair<int, std::uint64_t*>> queries;
    for (int axis = 0; axis < 3; ++axis) {
      const int b1 = (axis + 1) % 3, b2 = (axis + 2) % 3;
      int key[3];
      for (key[b1] = r.lo[b1]; key[b1] <= r.hi[b1]; ++key[b1])
        for (key[b2] = r.lo[b2]; key[b2] <= r.hi[b2]; ++key[b2]) {
          solver.clear();
          queries.clear();
          for (int p = r.lo[axis]; p <= r.hi[axis]; ++p) {
            key[axis] = p;
            std::uint64_t& w = at(key[0], key[1], key[2]);
            if (!isFreeWord(w)) {
              solver.add(p, 0.0, rockWord(key[0], key[1], key[2]));
            } else {
              if (hasSite(w)) solver.add(p, partialF(key, w, axis), w & kKeyMask);
              queries.emplace_back(p, &w);
            }
          }
          if (queries.empty()) continue;
          if (solver.empty()) {
            for (auto& q : queries) *q.second = kFreeBit;
            continue;
          }
          solver.prepare();
          for (auto& [p, w] : queries) *w = kFreeBit | kSiteBit | solver.solve(p);
        }
    }
    double worst = 0;
    for (int z = write.lo[2]; z <= write.hi[2]; ++z)
      for (int y = write.lo[1]; y <= write.hi[1]; ++y)
        for (int x = write.lo[0]; x <= write.hi[0]; ++x) {
          const std::uint64_t w = at(x, y, z);
          if (!isFreeWord(w)) continue;
          if (!hasSite(w)) return std::numeric_limits<double>::infinity();
          const double dx = x - siteCoord(w, 0), dy = y - siteCoord(w, 1), dz = z - siteCoord(w, 2);
          worst = std::max(worst, std::sqrt(dx * dx + dy * dy + dz * dz));
        }
    for (int z = write.lo[2]; z <= write.hi[2]; ++z)
      for (int y = write.lo[1]; y <= write.hi[1]; ++y)
        for (int x = write.lo[0]; x <= write.hi[0]; ++x) {
          const std::int32_t b = blockIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
          if (b >= 0) blocks[std::size_t(b)][std::size_t(localIndex(x, y, z))] = at(x, y, z);
        }
    return worst;
  }

  void refreshMemoryStats() {
    stats.blocks = blocks.size();
    stats.index_entries = index.size();
    stats.memory_bytes = blocks.size() * sizeof(Block) + index.size() * sizeof(std::int32_t) +
                         block_coords.size() * sizeof(block_coords[0]);
  }

  void refreshStats() {
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
};

DistanceField::DistanceField(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DistanceField::DistanceField(DistanceField&&) noexcept = default;
DistanceField& DistanceField::operator=(DistanceField&&) noexcept = default;
DistanceField::DistanceField(const DistanceField& o) : impl_(std::make_unique<Impl>(*o.impl_)) {}
DistanceField& DistanceField::operator=(const DistanceField& o) {
  if (this != &o) impl_ = std::make_unique<Impl>(*o.impl_);
  return *this;
}
DistanceField::~DistanceField() = default;

double DistanceField::resolution() const { return impl_->res; }
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

  // One walk of the octree creates the tiles on demand and marks the free voxels; the dense
  // tile index is built afterwards from the tiles' coordinates.
  std::unordered_map<std::uint64_t, std::uint32_t> tile_of;
  std::uint64_t last_key = ~std::uint64_t{0};
  Block* last_tile = nullptr;
  // A fill ratio of 1/4 is typical of roadways; the cap keeps a hostile map from reserving more
  // than 2 GiB up front (the vector still grows past it when the tiles are really there).
  impl->blocks.reserve(std::size_t(std::min(
      {double(max_blocks), 4.0 * double(map.stats().free_voxels) / kBlockVoxels + 64, 65536.0})));
  adviseHugePages(impl->blocks);
  bool overflow = false;
  auto tile = [&](int bx, int by, int bz) -> Block* {
    const std::uint64_t key = internal::packBlock(bx, by, bz);
    if (key == last_key) return last_tile;
    auto [it, inserted] = tile_of.try_emplace(key, std::uint32_t(impl->blocks.size()));
    if (inserted) {
      if (impl->blocks.size() >= max_blocks) { overflow = true; tile_of.erase(it); return nullptr; }
      impl->appendTile({bx, by, bz});
    }
    last_key = key;
    last_tile = &impl->blocks[it->second];  // valid until the next appendTile()
    return last_tile;
  };
  // Sets a box of voxels free (or rock); a leaf of up to 16 voxels lies in one tile.
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
          Block* blk = tile(bx, by, bz);
          if (!blk) return;
          const int x0 = std::max(lo[0], bx << kBlockBits), x1 = std::min(hi[0], (bx << kBlockBits) + kBlockMask);
          const int y0 = std::max(lo[1], by << kBlockBits), y1 = std::min(hi[1], (by << kBlockBits) + kBlockMask);
          const int z0 = std::max(lo[2], bz << kBlockBits), z1 = std::min(hi[2], (bz << kBlockBits) + kBlockMask);
          for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y)
              for (int x = x0; x <= x1; ++x) (*blk)[std::size_t(localIndex(x, y, z))] = free ? kFreeBit : 0;
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
    // Occupied leaves inside the bounds only: the tiles there exist already.
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
                      " tiles of 16^3 voxels (" + std::to_string(max_blocks * 32 / 1024) + " MiB)");
  if (impl->blocks.empty()) return failedPrecondition("distance field: the map has no free voxel");
  ADIT_RETURN_IF_ERROR(impl->rebuildIndex());
  if (progress) progress("reading free space", 1.0);
  const auto t1 = std::chrono::steady_clock::now();
  impl->transformAll(progress);
  const auto t2 = std::chrono::steady_clock::now();
  impl->refreshStats();
  impl->stats.transform_seconds = std::chrono::duration<double>(t2 - t1).count();
  impl->stats.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return DistanceField(std::move(impl));
}

bool DistanceField::isFree(const Vec3& p) const noexcept {
  int k[3];
  return impl_->voxelKey(p, k) && isFreeWord(impl_->word(k[0], k[1], k[2]));
}

Vec3 DistanceField::nearestRockVoxel(const Vec3& p) const noexcept {
  const double res = impl_->res;
  int k[3];
  if (!impl_->voxelKey(p, k)) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  std::uint64_t w = impl_->word(k[0], k[1], k[2]);
  if (!isFreeWord(w)) w = rockWord(k[0], k[1], k[2]);
  if (!hasSite(w)) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  return {centreOf(siteCoord(w, 0), res), centreOf(siteCoord(w, 1), res), centreOf(siteCoord(w, 2), res)};
}

DistanceSample DistanceField::query(const Vec3& p) const noexcept {
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
  std::uint64_t words[8];
  if ((base[0] & kBlockMask) != kBlockMask && (base[1] & kBlockMask) != kBlockMask &&
      (base[2] & kBlockMask) != kBlockMask) {
    // Common case: all 8 in one tile, one index read; the 8 loads are independent.
    const std::int32_t b = m.blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits, base[2] >> kBlockBits);
    if (b < 0) return out;  // the whole neighbourhood, p's voxel included, is rock
    const std::uint64_t* blk = m.blocks[std::size_t(b)].data() + localIndex(base[0], base[1], base[2]);
    constexpr int kDy = kBlockSize, kDz = kBlockSize * kBlockSize;
    words[0] = blk[0];         words[1] = blk[1];
    words[2] = blk[kDy];       words[3] = blk[kDy + 1];
    words[4] = blk[kDz];       words[5] = blk[kDz + 1];
    words[6] = blk[kDz + kDy]; words[7] = blk[kDz + kDy + 1];
  } else {
    m.gatherAcrossTiles(base, words);
  }
  // Coordinates of p relative to the base voxel's centre, in voxels (each in [0, 1)).
  const double qx = ux - double(base[0] - internal::kKeyOffset) - 0.5;
  const double qy = uy - double(base[1] - internal::kKeyOffset) - 0.5;
  const double qz = uz - double(base[2] - internal::kKeyOffset) - 0.5;
  const int own_corner = (qx >= 0.5 ? 1 : 0) | (qy >= 0.5 ? 2 : 0) | (qz >= 0.5 ? 4 : 0);
  if (!isFreeWord(words[own_corner])) return out;
  // Distance from p to each candidate site's cube, branch-free; a rock corner is its own site.
  double best = std::numeric_limits<double>::infinity();
  double bx = 0, by = 0, bz = 0;
  for (int c = 0; c < 8; ++c) {
    const std::uint64_t w = words[c];
    const bool free = isFreeWord(w);
    const double sx = free ? double(siteCoord(w, 0) - base[0]) : double(c & 1);
    const double sy = free ? double(siteCoord(w, 1) - base[1]) : double((c >> 1) & 1);
    const double sz = free ? double(siteCoord(w, 2) - base[2]) : double(c >> 2);
    const double ex = std::max(std::abs(qx - sx) - 0.5, 0.0);
    const double ey = std::max(std::abs(qy - sy) - 0.5, 0.0);
    const double ez = std::max(std::abs(qz - sz) - 0.5, 0.0);
    const double d2 = (free && !hasSite(w)) ? std::numeric_limits<double>::infinity() : ex * ex + ey * ey + ez * ez;
    const bool better = d2 < best;
    best = better ? d2 : best;
    bx = better ? std::copysign(ex, qx - sx) : bx;
    by = better ? std::copysign(ey, qy - sy) : by;
    bz = better ? std::copysign(ez, qz - sz) : bz;
  }
  if (!(best < std::numeric_limits<double>::infinity())) return out;  // no rock known
  out.in_rock = false;
  out.distance = std::sqrt(best) * m.res;
  const double dx = bx * m.res, dy = by * m.res, dz = bz * m.res;
  out.nearest = Vec3(px - dx, py - dy, pz - dz);
  if (out.distance > 0) {
    const double r = 1.0 / out.distance;
    out.gradient = Vec3(dx * r, dy * r, dz * r);
  }
  return out;
}

Status DistanceField::update(const OccupancyMap& map, const Aabb& changed) {
  Impl& m = *impl_;
  if (std::abs(map.resolution() - m.res) > 1e-12) return invalidArgument("distance field update: map resolution differs");
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
  if (window_voxels > std::max(4.0 * double(m.blocks.size()) * kBlockVoxels, 1e6)) {
    StatusOr<DistanceField> fresh = build(map);
    if (!fresh.ok()) return fresh.status();
    *this = std::move(fresh).value();
    return {};
  }
  // Re-read the changed voxels; new free space outside the tiles gets tiles.
  std::vector<std::array<int, 3>> coords;
  std::vector<std::array<int, 3>> now_free;
  std::int64_t free_delta = 0;
  for (int z = w.lo[2]; z <= w.hi[2]; ++z)
    for (int y = w.lo[1]; y <= w.hi[1]; ++y)
      for (int x = w.lo[0]; x <= w.hi[0]; ++x) {
        const Vec3 c(centreOf(x, m.res), centreOf(y, m.res), centreOf(z, m.res));
        const bool was_free = isFreeWord(m.word(x, y, z));
        if (map.isFree(c)) {
          now_free.push_back({x, y, z});
          coords.push_back({x >> kBlockBits, y >> kBlockBits, z >> kBlockBits});
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
  // Voxels whose nearest rock may change lie within the largest clearance of the window.
  const int grow = int(std::ceil(m.stats.max_distance_m / m.res)) + 2;
  BoxI write;
  for (int a = 0; a < 3; ++a) { write.lo[a] = std::max(0, w.lo[a] - grow); write.hi[a] = std::min(65535, w.hi[a] + grow); }
  int margin = grow + 1;
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
      break;
    }
    worst = m.transformBox(r, write);
    if (worst <= margin || whole) break;
    margin *= 2;
  }
  // Incremental statistics: a full scan would cost as much as the update itself. The largest
  // clearance only grows here (it stays an upper bound, which is all update() needs of it).
  m.refreshMemoryStats();
  m.stats.free_voxels = std::uint64_t(std::int64_t(m.stats.free_voxels) + free_delta);
  if (std::isfinite(worst)) m.stats.max_distance_m = std::max(m.stats.max_distance_m, worst * m.res);
  return {};
}

}  // namespace adit::map
