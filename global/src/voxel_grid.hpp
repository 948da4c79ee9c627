// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A sparse grid of per-voxel values over a map's voxel lattice, in 8^3 tiles behind a dense tile
// index: the free-space graph's working memory and its voxel -> piece locator. Only tiles that
// hold a set voxel are allocated, so memory follows the free space, not the bounding box (a mine's
// box is mostly rock). Voxel (i, j, k) is the octree voxel whose centre is ((i, j, k) + 0.5) * res.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "adit/map/types.hpp"

namespace adit::global {

struct VoxelIndex {
  int x = 0, y = 0, z = 0;
  bool operator==(const VoxelIndex& o) const { return x == o.x && y == o.y && z == o.z; }
};

template <class T>
class VoxelGrid {
 public:
  static constexpr int kShift = 3, kEdge = 1 << kShift, kTileVoxels = kEdge * kEdge * kEdge;

  VoxelGrid() = default;
  /// A grid over the voxels [lo, hi] (inclusive) holding `empty` everywhere.
  VoxelGrid(VoxelIndex lo, VoxelIndex hi, T empty) : lo_(lo), empty_(empty) {
    tiles_dims_ = {((hi.x - lo.x) >> kShift) + 1, ((hi.y - lo.y) >> kShift) + 1, ((hi.z - lo.z) >> kShift) + 1};
  }
  /// Tiles the dense index would need (4 bytes each): callers check this before building.
  static std::uint64_t indexCells(VoxelIndex lo, VoxelIndex hi) {
    return std::uint64_t(((hi.x - lo.x) >> kShift) + 1) * std::uint64_t(((hi.y - lo.y) >> kShift) + 1) *
           std::uint64_t(((hi.z - lo.z) >> kShift) + 1);
  }
  void allocateIndex() { index_.assign(std::size_t(tiles_dims_[0]) * tiles_dims_[1] * tiles_dims_[2], kNone); }

  T get(const VoxelIndex& v) const {
    const std::int64_t t = tileOf(v);
    if (t < 0) return empty_;
    const std::uint32_t slot = index_[std::size_t(t)];
    if (slot == kNone) return empty_;
    return tiles_[std::size_t(slot) * kTileVoxels + inTile(v)];
  }
  /// Writable cell, allocating its tile. `v` must lie in the grid's range.
  T& at(const VoxelIndex& v) {
    const std::int64_t t = tileOf(v);
    std::uint32_t& slot = index_[std::size_t(t)];
    if (slot == kNone) {
      slot = std::uint32_t(tiles_.size() / kTileVoxels);
      tiles_.resize(tiles_.size() + kTileVoxels, empty_);
      tile_origin_.push_back(tileOrigin(t));
    }
    return tiles_[std::size_t(slot) * kTileVoxels + inTile(v)];
  }
  /// A grid with the same tiles (same order) holding `empty`: a second layer over the same voxels.
  template <class U>
  VoxelGrid<U> sameShape(U empty) const {
    VoxelGrid<U> g;
    g.lo_ = lo_;
    g.tiles_dims_ = tiles_dims_;
    g.empty_ = empty;
    g.index_ = index_;
    g.tile_origin_ = tile_origin_;
    g.tiles_.assign(tiles_.size(), empty);
    return g;
  }
  std::size_t tileCount() const { return tile_origin_.size(); }
  VoxelIndex tileOrigin(std::size_t tile) const { return tile_origin_[tile]; }
  /// Cell `k` (0..511, x fastest) of allocated tile `tile`.
  T& cell(std::size_t tile, int k) { return tiles_[tile * kTileVoxels + std::size_t(k)]; }
  T cell(std::size_t tile, int k) const { return tiles_[tile * kTileVoxels + std::size_t(k)]; }
  static VoxelIndex offset(int k) { return {k & (kEdge - 1), (k >> kShift) & (kEdge - 1), k >> (2 * kShift)}; }
  std::uint64_t bytes() const {
    return tiles_.size() * sizeof(T) + index_.size() * sizeof(std::uint32_t) + tile_origin_.size() * sizeof(VoxelIndex);
  }

 private:
  template <class U>
  friend class VoxelGrid;
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::int64_t tileOf(const VoxelIndex& v) const {
    const int tx = (v.x - lo_.x) >> kShift, ty = (v.y - lo_.y) >> kShift, tz = (v.z - lo_.z) >> kShift;
    if (v.x < lo_.x || v.y < lo_.y || v.z < lo_.z || tx >= tiles_dims_[0] || ty >= tiles_dims_[1] ||
        tz >= tiles_dims_[2] || index_.empty())
      return -1;
    return std::int64_t(tx) + std::int64_t(tiles_dims_[0]) * (std::int64_t(ty) + std::int64_t(tiles_dims_[1]) * tz);
  }
  int inTile(const VoxelIndex& v) const {
    return ((v.x - lo_.x) & (kEdge - 1)) | (((v.y - lo_.y) & (kEdge - 1)) << kShift) |
           (((v.z - lo_.z) & (kEdge - 1)) << (2 * kShift));
  }
  VoxelIndex tileOrigin(std::int64_t t) const {
    const int tx = int(t % tiles_dims_[0]), ty = int((t / tiles_dims_[0]) % tiles_dims_[1]),
              tz = int(t / (std::int64_t(tiles_dims_[0]) * tiles_dims_[1]));
    return {lo_.x + (tx << kShift), lo_.y + (ty << kShift), lo_.z + (tz << kShift)};
  }
  VoxelIndex lo_;
  std::array<int, 3> tiles_dims_{0, 0, 0};
  T empty_{};
  std::vector<std::uint32_t> index_;
  std::vector<T> tiles_;
  std::vector<VoxelIndex> tile_origin_;
};

}  // namespace adit::global
