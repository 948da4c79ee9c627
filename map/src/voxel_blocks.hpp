// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private: a sparse set of voxels in OctoMap key space, stored as 16^3 bit blocks, and the key
// arithmetic shared by the voxelizer and the distance field. Keys are OctoMap's:
// key = floor(c / res) + 32768, voxel centre = (key - 32768 + 0.5) * res.
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace adit::map::internal {

constexpr int kKeyOffset = 32768;
constexpr int kBlockBits = 4;
constexpr int kBlockSize = 1 << kBlockBits;  // voxels per block edge
constexpr int kBlockMask = kBlockSize - 1;
constexpr int kBlockVoxels = kBlockSize * kBlockSize * kBlockSize;
// The distance field splits each block into tiles of (1 << kFieldTileBits)^3 voxels (see
// distance_field_impl.hpp); the size estimate counts them.
constexpr int kFieldTileBits = 2;

// floor() for |v| < 2^31 without a libm call (baseline x86-64 has no SSE4.1 round): the
// distance field's hot path takes six of them per query.
inline int floorToInt(double v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<double>(i) > v);
}
// Same value as octomap::OcTreeBaseImpl::coordToKey, so voxels agree bit for bit. Callers keep
// |c / res| well inside the int range (maps are checked against the key range first).
inline int keyOf(double c, double inv_res) { return floorToInt(inv_res * c) + kKeyOffset; }
inline double centreOf(int key, double res) { return (double(key - kKeyOffset) + 0.5) * res; }

inline std::uint64_t packBlock(int bx, int by, int bz) {
  return (std::uint64_t(std::uint32_t(bx)) << 42) | (std::uint64_t(std::uint32_t(by)) << 21) |
         std::uint64_t(std::uint32_t(bz));
}

// Rows along x are 16-bit words; a block is 256 rows indexed y + 16 z.
class BitVoxelSet {
 public:
  using Block = std::array<std::uint16_t, kBlockSize * kBlockSize>;

  void set(int x, int y, int z) { row(x >> kBlockBits, y, z) |= std::uint16_t(1u << (x & kBlockMask)); }
  bool test(int x, int y, int z) const {
    const Block* b = find(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits);
    return b && ((*b)[(y & kBlockMask) + kBlockSize * (z & kBlockMask)] >> (x & kBlockMask)) & 1u;
  }
  // Row of block column bx at voxel (y, z), creating the block if needed.
  std::uint16_t& row(int bx, int y, int z) {
    Block& b = block(bx, y >> kBlockBits, z >> kBlockBits);
    return b[(y & kBlockMask) + kBlockSize * (z & kBlockMask)];
  }
  const Block* find(int bx, int by, int bz) const {
    auto it = index_.find(packBlock(bx, by, bz));
    return it == index_.end() ? nullptr : &blocks_[it->second];
  }
  Block& block(int bx, int by, int bz) {
    auto [it, inserted] = index_.try_emplace(packBlock(bx, by, bz), std::uint32_t(blocks_.size()));
    if (inserted) {
      blocks_.emplace_back();
      blocks_.back().fill(0);
      coords_.push_back({bx, by, bz});
    }
    return blocks_[it->second];
  }
  std::size_t blockCount() const { return blocks_.size(); }
  const std::array<int, 3>& blockCoord(std::size_t i) const { return coords_[i]; }
  const Block& blockAt(std::size_t i) const { return blocks_[i]; }
  std::uint64_t count() const {
    std::uint64_t n = 0;
    for (const Block& b : blocks_) for (std::uint16_t r : b) n += std::uint64_t(__builtin_popcount(r));
    return n;
  }
  // fn(x, y, z) for every voxel in the set.
  template <class Fn>
  void forEach(Fn&& fn) const {
    for (std::size_t i = 0; i < blocks_.size(); ++i) {
      const auto& c = coords_[i];
      for (int r = 0; r < kBlockSize * kBlockSize; ++r) {
        unsigned bits = blocks_[i][r];
        while (bits) {
          const int bx = __builtin_ctz(bits);
          bits &= bits - 1;
          fn((c[0] << kBlockBits) + bx, (c[1] << kBlockBits) + (r & kBlockMask), (c[2] << kBlockBits) + (r >> kBlockBits));
        }
      }
    }
  }

 private:
  std::unordered_map<std::uint64_t, std::uint32_t> index_;
  std::vector<Block> blocks_;
  std::vector<std::array<int, 3>> coords_;
};

}  // namespace adit::map::internal
