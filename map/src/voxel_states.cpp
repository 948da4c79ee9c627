// SPDX-License-Identifier: BSD-3-Clause
#include "voxel_states.hpp"

#include <algorithm>
#include <cstring>

#include "adit/status.hpp"
#include "octree_stream.hpp"

namespace adit::map {

namespace {

constexpr std::uint64_t kUnknownWord = 0xAAAAAAAAAAAAAAAAull;  // 2 (kUnknown) in every 2 bits

}  // namespace

std::unique_ptr<VoxelStates> VoxelStates::fromStream(const std::string& data, float occupied_log_odds) {
  static_assert(unsigned(VoxelState::kFree) == 0 && unsigned(VoxelState::kOccupied) == 1 &&
                unsigned(VoxelState::kUnknown) == 2);
  if (data.size() < 5) return nullptr;
  // First pass: the leaves' key range, in superblocks, and how many superblocks and bricks are
  // split. The stream is depth first, so the leaves inside one superblock (or brick) come one
  // after another: a split one is a run of smaller leaves, counted once (the arrays are then
  // allocated once, not grown).
  std::array<unsigned, 3> lo{~0u, ~0u, ~0u}, hi{0, 0, 0};
  std::size_t split = 0, mixed = 0;
  std::uint64_t last_split = ~std::uint64_t{0}, last_mixed = ~std::uint64_t{0};
  auto pack = [](const std::array<unsigned, 3>& o, int shift) {
    return (std::uint64_t(o[0] >> shift) << 32) | (std::uint64_t(o[1] >> shift) << 16) | std::uint64_t(o[2] >> shift);
  };
  forEachStreamLeaf(data, [&](const StreamNode& n) {
    const std::array<unsigned, 3>& o = n.origin;
    const unsigned size = n.edge;
    for (int a = 0; a < 3; ++a) {
      lo[std::size_t(a)] = std::min(lo[std::size_t(a)], o[std::size_t(a)] >> 6);
      hi[std::size_t(a)] = std::max(hi[std::size_t(a)], (o[std::size_t(a)] + size - 1) >> 6);
    }
    if (size >= 64) return;
    if (const std::uint64_t k = pack(o, 6); k != last_split) {
      ++split;
      last_split = k;
    }
    if (size >= 8) return;
    if (const std::uint64_t k = pack(o, 3); k != last_mixed) {
      ++mixed;
      last_mixed = k;
    }
  });
  auto s = std::unique_ptr<VoxelStates>(new VoxelStates());
  if (lo[0] > hi[0]) {  // no leaf at all
    s->top_.assign(1, std::uint32_t(VoxelState::kUnknown));
    s->dim_ = {1, 1, 1};
    return s;
  }
  std::size_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    s->lo_[std::size_t(a)] = int(lo[std::size_t(a)]);
    s->dim_[std::size_t(a)] = int(hi[std::size_t(a)] - lo[std::size_t(a)] + 1);
    cells *= std::size_t(s->dim_[std::size_t(a)]);
  }
  if (cells > kMaxSuperblocks) return nullptr;
  s->top_.assign(cells, std::uint32_t(VoxelState::kUnknown));
  s->sub_.reserve(split * 512);
  s->bricks_.reserve(mixed);
  forEachStreamLeaf(data, [&](const StreamNode& n) {
    s->mark(n.origin, n.edge, n.log_odds >= occupied_log_odds ? VoxelState::kOccupied : VoxelState::kFree);
  });
  ADIT_DEMAND(s->sub_.size() == split * 512 && s->bricks_.size() == mixed);
  return s;
}

// Leaves partition space, so a cube given here was never split before and is set whole: a
// superblock or brick inside it gets its state as one code, a smaller cube its voxels' bits.
void VoxelStates::mark(const std::array<unsigned, 3>& o, unsigned size, VoxelState state) {
  const auto code = std::uint32_t(state);
  auto topAt = [this](unsigned x, unsigned y, unsigned z) -> std::uint32_t& {
    return top_[(std::size_t(z - unsigned(lo_[2])) * unsigned(dim_[1]) + (y - unsigned(lo_[1]))) * unsigned(dim_[0]) +
                (x - unsigned(lo_[0]))];
  };
  if (size >= 64) {
    for (unsigned z = o[2] >> 6; z < (o[2] + size) >> 6; ++z)
      for (unsigned y = o[1] >> 6; y < (o[1] + size) >> 6; ++y)
        for (unsigned x = o[0] >> 6; x < (o[0] + size) >> 6; ++x) topAt(x, y, z) = code;
    return;
  }
  std::uint32_t& top = topAt(o[0] >> 6, o[1] >> 6, o[2] >> 6);
  if (top < kSplit) {
    top = kSplit + std::uint32_t(sub_.size() / 512);
    sub_.resize(sub_.size() + 512, std::uint32_t(VoxelState::kUnknown));
  }
  std::uint32_t* sub = sub_.data() + std::size_t(top - kSplit) * 512;
  if (size >= 8) {
    for (unsigned z = o[2]; z < o[2] + size; z += 8)
      for (unsigned y = o[1]; y < o[1] + size; y += 8)
        for (unsigned x = o[0]; x < o[0] + size; x += 8) sub[brickSlot(x, y, z)] = code;
    return;
  }
  std::uint32_t& brick = sub[brickSlot(o[0], o[1], o[2])];
  if (brick < kSplit) {
    brick = kSplit + std::uint32_t(bricks_.size());
    Brick b;
    b.fill(kUnknownWord);
    bricks_.push_back(b);
  }
  Brick& bits = bricks_[brick - kSplit];
  for (unsigned z = o[2]; z < o[2] + size; ++z)
    for (unsigned y = o[1]; y < o[1] + size; ++y)
      for (unsigned x = o[0]; x < o[0] + size; ++x) {
        const unsigned v = voxelSlot(x, y, z), shift = (v & 31u) * 2;
        bits[v >> 5] = (bits[v >> 5] & ~(std::uint64_t{3} << shift)) | (std::uint64_t(code) << shift);
      }
}

}  // namespace adit::map
