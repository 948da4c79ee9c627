// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// VoxelStates: the raw state of every voxel of an octree read from OcTree::writeData's stream,
// answered by key without building the octree's nodes. A map read from the cache holds its octree
// as bytes; building its 2.6 million nodes (two allocations each) took every campaign worker and
// every `simulate` a quarter of a second and a hundred megabytes, only to answer the voxel
// queries of a sensor's rays. This answers them from two array reads and, near rock, a bit read,
// in 3.8 MB on the district, which workers forked after it is built share.
//
// Layout: the leaves' key range in superblocks of 64^3 voxels (a dense array of codes), each
// superblock either one state or 512 bricks of 8^3 voxels, each brick either one state or 2 bits
// a voxel. A leaf of the octree covers a power-of-two cube aligned to its size, so a superblock or
// a brick lies inside one leaf or is split by smaller ones: the codes are exact.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "adit/map/occupancy_map.hpp"

namespace adit::map {

class VoxelStates {
 public:
  /// Reads a stream whose shape the cache reader checked (every node finite, depth <= 16, the
  /// bytes exactly used). A leaf is occupied when its log-odds is >= `occupied_log_odds`
  /// (OctoMap's isNodeOccupied). Null when the leaves span more than kMaxSuperblocks superblocks
  /// (a pruned leaf of kilometres): the caller builds the octree instead.
  static std::unique_ptr<VoxelStates> fromStream(const std::string& data, float occupied_log_odds);

  /// The state OcTree::search() would give for the voxel of key (x, y, z): a leaf's state, or
  /// unknown where no leaf covers it.
  VoxelState at(std::uint16_t x, std::uint16_t y, std::uint16_t z) const {
    const unsigned sx = unsigned(x >> 6) - unsigned(lo_[0]), sy = unsigned(y >> 6) - unsigned(lo_[1]),
                   sz = unsigned(z >> 6) - unsigned(lo_[2]);
    if (sx >= unsigned(dim_[0]) || sy >= unsigned(dim_[1]) || sz >= unsigned(dim_[2])) return VoxelState::kUnknown;
    std::uint32_t code = top_[(std::size_t(sz) * unsigned(dim_[1]) + sy) * unsigned(dim_[0]) + sx];
    if (code < kSplit) return VoxelState(code);
    code = sub_[std::size_t(code - kSplit) * 512 + brickSlot(x, y, z)];
    if (code < kSplit) return VoxelState(code);
    const unsigned v = voxelSlot(x, y, z);
    return VoxelState((bricks_[code - kSplit][v >> 5] >> ((v & 31u) * 2)) & 3u);
  }

  static constexpr std::size_t kMaxSuperblocks = std::size_t{1} << 22;  // 16 MiB of codes

 private:
  // Codes 0..2 are a uniform VoxelState (kFree = 0, kOccupied = 1, kUnknown = 2); kSplit + i
  // names entry i of the next level.
  static constexpr std::uint32_t kSplit = 3;
  using Brick = std::array<std::uint64_t, 16>;  // 512 voxels x 2 bits
  static unsigned brickSlot(unsigned x, unsigned y, unsigned z) {
    return (((z >> 3) & 7u) << 6) | (((y >> 3) & 7u) << 3) | ((x >> 3) & 7u);
  }
  static unsigned voxelSlot(unsigned x, unsigned y, unsigned z) { return ((z & 7u) << 6) | ((y & 7u) << 3) | (x & 7u); }
  void mark(const std::array<unsigned, 3>& origin, unsigned size, VoxelState state);

  std::array<int, 3> lo_{}, dim_{};  // in superblocks
  std::vector<std::uint32_t> top_;
  std::vector<std::uint32_t> sub_;
  std::vector<Brick> bricks_;
};

}  // namespace adit::map
