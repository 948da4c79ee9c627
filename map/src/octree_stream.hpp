// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// OcTree::writeData's stream, walked without building the octree. A cached map holds its octree
// as these bytes; the cache's shape check, the voxel states, the leaves of a map nobody wrote and
// the tree built from the bytes all read it through walkOctreeStream().
//
// The stream is, for each node depth first, its float log-odds and a byte whose bit i says child
// i follows; children come lowest bit first, and child bit 1 adds half the node's edge to its
// key's x, 2 to y, 4 to z (OcTreeKey's computeChildIdx).

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace adit::map {

struct StreamNode {
  int depth = 0;                     // the root 0, single voxels 16
  unsigned child = 0;                // its index in its parent (the root: 0)
  std::array<unsigned, 3> origin{};  // the key of its lowest corner
  unsigned edge = 0;                 // in voxels: 65536 >> depth
  float log_odds = 0.0f;
  unsigned mask = 0;                 // the children that follow it; 0: a leaf
};

struct StreamWalk {
  enum End { kWhole, kCut, kTooDeep, kStopped } end = kWhole;
  std::uint64_t nodes = 0;  // nodes read, the one a visit stopped at included
  std::size_t bytes = 0;    // bytes read
};

/// Calls visit(const StreamNode&) for every node in stream order until it returns false (kStopped),
/// the bytes end inside a node (kCut) or a node below depth 16 is named (kTooDeep). Bounds-checked,
/// so it walks bytes from outside too; bytes left after the tree end it as kWhole with `bytes`
/// short of the size. Without kOrigins the nodes' origins are left zero: the cache's check of the
/// district's 2.6 M nodes is then 70 M instructions instead of 125 M.
template <bool kOrigins = true, typename Visit>
StreamWalk walkOctreeStream(const std::string& data, Visit&& visit) {
  struct Level {
    unsigned pending;  // the children not yet read
    std::array<unsigned, 3> origin;
  };
  Level level[17];
  const char* const begin = data.data();
  const char* p = begin;
  const char* const last = begin + data.size();
  std::uint64_t nodes = 0;
  StreamNode n;
  auto read = [&](int depth, unsigned child, const std::array<unsigned, 3>& origin) {
    if (last - p < 5) return false;
    n.depth = depth;
    n.child = child;
    n.origin = origin;
    n.edge = 65536u >> depth;
    std::memcpy(&n.log_odds, p, sizeof n.log_odds);
    n.mask = static_cast<unsigned char>(p[4]);
    p += 5;
    ++nodes;
    return true;
  };
  auto end = [&](StreamWalk::End e) { return StreamWalk{e, nodes, std::size_t(p - begin)}; };
  if (!read(0, 0, {0, 0, 0})) return end(StreamWalk::kCut);
  if (!visit(static_cast<const StreamNode&>(n))) return end(StreamWalk::kStopped);
  level[0] = {n.mask, n.origin};
  int depth = 0;
  while (depth >= 0) {
    unsigned& left = level[depth].pending;
    if (left == 0) {
      --depth;
      continue;
    }
    const auto child = unsigned(__builtin_ctz(left));
    left &= left - 1;
    if (depth == 16) return end(StreamWalk::kTooDeep);
    std::array<unsigned, 3> origin{};
    if constexpr (kOrigins) {
      const unsigned half = 1u << (15 - depth);
      const std::array<unsigned, 3>& o = level[depth].origin;
      origin = {o[0] + ((child & 1u) ? half : 0u), o[1] + ((child & 2u) ? half : 0u), o[2] + ((child & 4u) ? half : 0u)};
    }
    if (!read(depth + 1, child, origin)) return end(StreamWalk::kCut);
    if (!visit(static_cast<const StreamNode&>(n))) return end(StreamWalk::kStopped);
    if (n.mask != 0) level[++depth] = {n.mask, n.origin};
  }
  return end(StreamWalk::kWhole);
}

/// leaf(const StreamNode&) for every leaf (a node without children), in stream order; for bytes
/// whose shape was checked.
template <typename Leaf>
void forEachStreamLeaf(const std::string& data, Leaf&& leaf) {
  walkOctreeStream(data, [&leaf](const StreamNode& n) {
    if (n.mask == 0) leaf(n);
    return true;
  });
}

}  // namespace adit::map
