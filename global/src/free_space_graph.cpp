// SPDX-License-Identifier: BSD-3-Clause
// The roadway graph of a map without a survey, built on the robot's configuration space.
//
// Why a Reeb graph of geodesic distance and not a cell lattice or a thinned skeleton: a lattice
// of cells joins neighbouring cells by the line of sight between two sample points, so it both
// misses passages (a bend, a neck narrower than a cell) and invents them (a thin wall inside one
// cell); voxel thinning (medial axis) is exact in topology but leaves hairy surfaces in rough
// scans and wide chambers. Slicing each connected part of the configuration space by breadth-
// first distance from a far end keeps the exact connectivity of the voxels (every voxel is in
// exactly one piece, touching pieces are joined) and gives one piece per slice along a roadway
// of any width, several where it branches, and a cycle wherever the map has a loop (the two
// fronts meet in one piece).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>

#include "adit/global/roadway_graph.hpp"
#include "adit/map/size_estimate.hpp"
#include "free_space_index.hpp"
#include "geometry.hpp"

namespace adit::global {

using map::Aabb;
using map::Polyline;

namespace {

constexpr VoxelIndex kFaces[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

VoxelIndex plus(const VoxelIndex& a, const VoxelIndex& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 centre(const VoxelIndex& v, double res) { return (Vec3(v.x, v.y, v.z) + Vec3::Constant(0.5)) * res; }
// A voxel as one 63-bit key (21 bits per axis, OctoMap's 16-bit key range fits) for hash sets.
std::uint64_t key(const VoxelIndex& v) {
  return (std::uint64_t(std::uint32_t(v.x) & 0x1fffff) << 42) | (std::uint64_t(std::uint32_t(v.y) & 0x1fffff) << 21) |
         std::uint64_t(std::uint32_t(v.z) & 0x1fffff);
}
VoxelIndex voxelOf(const Vec3& p, double res) {
  return {int(std::floor(p.x() / res)), int(std::floor(p.y() / res)), int(std::floor(p.z() / res))};
}

// Working memory per voxel slot of the build: breadth-first depth and piece (4 + 4 bytes),
// clearance (4); tiles of 8^3 are about half free in roadways (measured on the district: 51 %).
constexpr double kBuildBytesPerFreeVoxel = 12.0 / 0.5 + 12.0;  // grids + queue

// Breadth-first, face to face, from `from` over the voxels whose piece `allowed` accepts and
// that `step_ok(v, w)` lets through; `visit(v)` sees every voxel reached. Returns the voxel
// centres from `from` to `target` when it is reached (empty otherwise); with `stop_at_target`
// the search ends there. One flood for the axes' detours round bends and for re-checking a
// passage after the map changed.
template <class Allowed, class StepOk, class Visit>
std::vector<Vec3> floodPieces(const VoxelGrid<std::int32_t>& piece_of, double res, const VoxelIndex& from,
                              const VoxelIndex& target, bool stop_at_target, Allowed allowed, StepOk step_ok,
                              Visit visit) {
  std::unordered_set<std::uint64_t> seen{key(from)};
  std::vector<VoxelIndex> open{from};
  std::vector<std::uint32_t> parent{0xffffffffu};
  std::vector<Vec3> path;
  for (std::size_t h = 0; h < open.size(); ++h) {
    const VoxelIndex v = open[h];
    visit(v);
    if (v == target && path.empty()) {
      for (std::uint32_t i = std::uint32_t(h); i != 0xffffffffu; i = parent[i]) path.push_back(centre(open[i], res));
      std::reverse(path.begin(), path.end());
      if (stop_at_target) break;
    }
    for (const VoxelIndex& f : kFaces) {
      const VoxelIndex w = plus(v, f);
      if (!allowed(piece_of.get(w)) || seen.count(key(w)) || !step_ok(v, w)) continue;
      seen.insert(key(w));
      open.push_back(w);
      parent.push_back(std::uint32_t(h));
    }
  }
  return path;
}

// Greedy line-of-sight shortening with doubling steps: long straight passages cost O(log n)
// checks per kept point instead of O(n).
std::vector<Vec3> straightenAxis(const map::DistanceField& field, const std::vector<Vec3>& pts, double need) {
  const double step = 0.5 * field.resolution();
  std::vector<Vec3> out{pts.front()};
  std::size_t i = 0;
  while (i + 1 < pts.size()) {
    std::size_t good = i + 1, stride = 1;
    while (good + stride < pts.size() && segmentClear(field, pts[i], pts[good + stride], need, step))
      good += stride, stride *= 2;
    for (; stride > 1; stride /= 2)
      if (good + stride / 2 < pts.size() && segmentClear(field, pts[i], pts[good + stride / 2], need, step))
        good += stride / 2;
    out.push_back(pts[good]);
    i = good;
  }
  if (out.size() == 1) out.push_back(out.front());
  return out;
}

}  // namespace

StatusOr<RoadwayGraph> RoadwayGraph::fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                                   double required_clearance_m, double slice_m) {
  FreeSpaceGraphOptions o;
  o.slice_m = slice_m;
  return fromFreeSpace(map, field, required_clearance_m, o);
}

StatusOr<RoadwayGraph> RoadwayGraph::fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                                   double required_clearance_m,
                                                   const FreeSpaceGraphOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(options.slice_m > 0) || !std::isfinite(options.slice_m))
    return invalidArgument("free-space graph: slice thickness must be > 0 m");
  if (!std::isfinite(required_clearance_m) || required_clearance_m < 0)
    return invalidArgument("free-space graph: required clearance must be >= 0 m");
  const Aabb bounds = map.bounds();
  if (bounds.empty()) return failedPrecondition("the map has no free space to build a roadway graph from");
  const double res = field.resolution();
  const VoxelIndex lo = voxelOf(bounds.min + Vec3::Constant(0.5 * res), res);
  const VoxelIndex hi = voxelOf(bounds.max - Vec3::Constant(0.5 * res), res);
  if (hi.x < lo.x || hi.y < lo.y || hi.z < lo.z) return failedPrecondition("the map's bounds hold no voxel");

  // Estimate before allocating: a map too large says so instead of growing until it is killed.
  const bool unknown_is_free = map.unknownPolicy() == map::UnknownPolicy::kFree;
  const std::uint64_t free_voxels =
      map.stats().free_voxels + (unknown_is_free ? map.stats().unknown_voxels : 0);
  const std::uint64_t index_cells = VoxelGrid<int>::indexCells(lo, hi);
  const double estimate = double(free_voxels) * kBuildBytesPerFreeVoxel + double(index_cells) * 4.0 * 3.0;
  {
    std::ostringstream what;
    what << "the free-space roadway graph of this map (" << free_voxels << " free voxels of " << res << " m)";
    ADIT_RETURN_IF_ERROR(map::MemoryBudget{options.max_memory_bytes}.check(
        estimate, what.str(), "convert the map at a coarser --resolution, --crop it to the district you plan in, "
                              "or give it a survey"));
  }
  auto progress = [&](const char* stage, double f) {
    if (options.progress) options.progress(stage, f);
  };

  // 1. The configuration space: free voxel centres with clearance >= required.
  VoxelGrid<std::int32_t> depth(lo, hi, -1);  // -1 not in it, -2 unvisited, -3 seen by the first sweep, >= 0 depth
  VoxelGrid<float> clearance(lo, hi, 0.0f);
  depth.allocateIndex();
  clearance.allocateIndex();
  std::uint64_t voxels = 0;
  auto consider = [&](const VoxelIndex& v) {
    const double d = field.distance(centre(v, res));
    if (d < required_clearance_m) return;
    if (depth.at(v) == -1) ++voxels;
    depth.at(v) = -2;
    clearance.at(v) = float(d);
  };
  if (!unknown_is_free) {
    std::uint64_t leaves = 0;
    map.forEachLeaf([&](const Vec3& c, double size, map::VoxelState state) {
      if (state != map::VoxelState::kFree) return;
      if ((++leaves & 0xffff) == 0) progress("free-space graph: configuration space", 0.0);
      const int n = std::max(1, int(std::lround(size / res)));
      const VoxelIndex v0 = voxelOf(c - Vec3::Constant(0.5 * size - 0.5 * res), res);
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const VoxelIndex v{v0.x + i, v0.y + j, v0.z + k};
            if (v.x < lo.x || v.y < lo.y || v.z < lo.z || v.x > hi.x || v.y > hi.y || v.z > hi.z) continue;
            consider(v);
          }
    });
  } else {
    for (int z = lo.z; z <= hi.z; ++z) {
      progress("free-space graph: configuration space", double(z - lo.z) / double(hi.z - lo.z + 1));
      for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x)
          if (field.isFree(centre({x, y, z}, res))) consider({x, y, z});
    }
  }
  if (voxels == 0) {
    std::ostringstream m;
    m.precision(2);
    m << std::fixed << "no free space with clearance >= " << required_clearance_m
      << " m: the robot fits nowhere in this map, so there is no roadway graph";
    return failedPrecondition(m.str());
  }

  // 2. Each connected part: a breadth-first sweep from any voxel finds a far end, the geodesic
  //    distance from there gives every voxel its depth; the pieces of each slice are flood-filled.
  const int slice = 10 * std::max(1, int(std::lround(options.slice_m / res)));  // chamfer units
  VoxelGrid<std::int32_t> piece_of = depth.sameShape<std::int32_t>(-1);
  struct PieceBuild {
    VoxelIndex best, lo, hi;
    float best_clearance = -1;
    int region = 0;
  };
  struct Region {
    VoxelIndex root, far;
  };
  std::vector<PieceBuild> pieces;
  std::vector<Region> regions;
  std::vector<std::uint64_t> touching;  // (a << 32 | b), a < b: pieces that share a face
  std::vector<VoxelIndex> queue, fill;
  std::uint64_t visited = 0;
  // The part's voxels, breadth-first (face to face) from `from`, marked -3; returns the last.
  auto sweep = [&](const VoxelIndex& from) {
    queue.clear();
    queue.push_back(from);
    depth.at(from) = -3;
    for (std::size_t head = 0; head < queue.size(); ++head)
      for (const VoxelIndex& f : kFaces) {
        const VoxelIndex w = plus(queue[head], f);
        if (depth.get(w) != -2) continue;
        depth.at(w) = -3;
        queue.push_back(w);
      }
    return queue.back();
  };
  // Geodesic distance from `root` over the part (marked -3) in chamfer units (10 per voxel
  // face step, 14 and 17 for the diagonals: within a few per cent of Euclidean), by Dial's bucket
  // queue; `queue` receives the voxels in the order they are settled. Breadth-first depth (the
  // Manhattan metric) would not do: its fronts run diagonally across a junction and join a
  // branch to the roadway it leaves for metres beyond the corner.
  std::vector<std::vector<VoxelIndex>> buckets(18);
  std::vector<std::pair<VoxelIndex, int>> steps;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        const int n = std::abs(x) + std::abs(y) + std::abs(z);
        if (n) steps.push_back({VoxelIndex{x, y, z}, n == 1 ? 10 : n == 2 ? 14 : 17});
      }
  auto geodesic = [&](const VoxelIndex& root) {
    queue.clear();
    depth.at(root) = 0;
    buckets[0].push_back(root);
    std::size_t pending = 1;
    for (std::int32_t d = 0; pending > 0; ++d) {
      std::vector<VoxelIndex>& b = buckets[std::size_t(d % 18)];
      for (std::size_t i = 0; i < b.size(); ++i) {
        const VoxelIndex v = b[i];
        --pending;
        if (depth.get(v) != d) continue;  // settled earlier at a smaller distance
        queue.push_back(v);
        for (const auto& [s, w] : steps) {
          const VoxelIndex n = plus(v, s);
          const std::int32_t dn = depth.get(n);
          // (A voxel of a part already sliced has a piece: a diagonal step must not reach it.)
          if (dn == -3 || (dn > d + w && piece_of.get(n) < 0)) {
            depth.at(n) = d + w;
            buckets[std::size_t((d + w) % 18)].push_back(n);
            ++pending;
          }
        }
      }
      b.clear();
    }
    return queue.back();
  };
  for (std::size_t t = 0; t < depth.tileCount(); ++t) {
    for (int k = 0; k < VoxelGrid<int>::kTileVoxels; ++k) {
      if (depth.cell(t, k) != -2) continue;
      const VoxelIndex seed = plus(depth.tileOrigin(t), VoxelGrid<int>::offset(k));
      const VoxelIndex far = sweep(seed);
      const VoxelIndex farther = geodesic(far);
      const int region = int(regions.size());
      regions.push_back({far, farther});
      // Pieces in breadth-first order, so piece numbers run from the root outwards.
      for (const VoxelIndex& v : queue) {
        if (piece_of.get(v) >= 0) continue;
        const int id = int(pieces.size());
        const std::int32_t band = depth.get(v) / slice;
        PieceBuild p;
        p.best = p.lo = p.hi = v;
        p.region = region;
        fill.clear();
        fill.push_back(v);
        piece_of.at(v) = id;
        for (std::size_t h = 0; h < fill.size(); ++h) {
          const VoxelIndex u = fill[h];
          const float c = clearance.get(u);
          if (c > p.best_clearance) p.best_clearance = c, p.best = u;
          p.lo = {std::min(p.lo.x, u.x), std::min(p.lo.y, u.y), std::min(p.lo.z, u.z)};
          p.hi = {std::max(p.hi.x, u.x), std::max(p.hi.y, u.y), std::max(p.hi.z, u.z)};
          for (const VoxelIndex& f : kFaces) {
            const VoxelIndex w = plus(u, f);
            const std::int32_t dw = depth.get(w);
            if (dw < 0 || dw / slice != band || piece_of.get(w) >= 0) continue;
            piece_of.at(w) = id;
            fill.push_back(w);
          }
        }
        pieces.push_back(p);
      }
      for (const VoxelIndex& v : queue) {
        const int a = piece_of.get(v);
        for (int f = 0; f < 6; f += 2) {  // +x, +y, +z: each face once
          const int b = piece_of.get(plus(v, kFaces[f]));
          if (b < 0 || b == a) continue;
          touching.push_back((std::uint64_t(std::min(a, b)) << 32) | std::uint64_t(std::max(a, b)));
        }
      }
      visited += queue.size();
      progress("free-space graph: slicing", double(visited) / double(voxels));
    }
  }
  const std::uint64_t peak_bytes = depth.bytes() + clearance.bytes() + piece_of.bytes() +
                                   queue.capacity() * sizeof(VoxelIndex) + touching.capacity() * 8;
  depth = VoxelGrid<std::int32_t>();
  clearance = VoxelGrid<float>();
  std::vector<VoxelIndex>().swap(queue);
  std::sort(touching.begin(), touching.end());
  touching.erase(std::unique(touching.begin(), touching.end()), touching.end());

  const std::size_t np = pieces.size();
  std::vector<std::vector<int>> adj(np);
  for (std::uint64_t t : touching) {
    const int a = int(t >> 32), b = int(t & 0xffffffffu);
    adj[std::size_t(a)].push_back(b);
    adj[std::size_t(b)].push_back(a);
  }
  std::vector<std::uint64_t>().swap(touching);
  std::vector<Vec3> pos(np);
  for (std::size_t i = 0; i < np; ++i) pos[i] = centre(pieces[i].best, res);

  // 3. Fold short branches (a niche in the rib, a bump of a scanned wall) into the piece they
  //    leave: a branch counts when it reaches farther than twice the clearance of that piece
  //    (the roadway's half-width there) and than two slices.
  std::vector<int> owner(np);  // piece a folded piece now belongs to
  for (std::size_t i = 0; i < np; ++i) owner[i] = int(i);
  std::vector<char> alive(np, 1);
  std::vector<int> degree(np);
  for (std::size_t i = 0; i < np; ++i) degree[i] = int(adj[i].size());
  auto nextAlive = [&](int at, int from) {
    for (int n : adj[std::size_t(at)])
      if (n != from && alive[std::size_t(n)]) return n;
    return -1;
  };
  std::uint64_t folded = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t s = 0; s < np; ++s) {
      if (!alive[s] || degree[s] != 1) continue;
      std::vector<int> chain{int(s)};
      double length = 0;
      int prev = int(s), cur = nextAlive(int(s), -1);
      while (cur >= 0 && degree[std::size_t(cur)] == 2) {
        length += (pos[std::size_t(cur)] - pos[std::size_t(prev)]).norm();
        chain.push_back(cur);
        const int nx = nextAlive(cur, prev);
        prev = cur;
        cur = nx;
      }
      if (cur < 0 || degree[std::size_t(cur)] < 3) continue;  // a whole passage with two ends
      length += (pos[std::size_t(cur)] - pos[std::size_t(prev)]).norm();
      const double reach = std::max(2.0 * options.slice_m, 2.0 * double(pieces[std::size_t(cur)].best_clearance));
      if (length >= reach) continue;
      for (int c : chain) alive[std::size_t(c)] = 0, owner[std::size_t(c)] = cur;
      --degree[std::size_t(cur)];
      ++folded;
      changed = true;
    }
  }
  // Blunt the tips: the last piece before a dead end's face is often a thin rim (the face's
  // corners are farthest from the root), its best point against the rock. Fold such tips into
  // the piece before them while they have under half its clearance.
  for (std::size_t s = 0; s < np; ++s) {
    int tip = int(s);
    while (alive[std::size_t(tip)] && degree[std::size_t(tip)] == 1) {
      const int q = nextAlive(tip, -1);
      if (q < 0 || degree[std::size_t(q)] > 2 ||
          pieces[std::size_t(tip)].best_clearance >= 0.5f * pieces[std::size_t(q)].best_clearance)
        break;
      alive[std::size_t(tip)] = 0, owner[std::size_t(tip)] = q;
      --degree[std::size_t(q)];
      tip = q;
    }
  }
  // Owners of owners (a branch folded into a piece that was folded later).
  for (std::size_t i = 0; i < np; ++i) {
    int o = owner[i];
    while (owner[std::size_t(o)] != o) o = owner[std::size_t(o)];
    owner[i] = o;
  }
  for (std::size_t i = 0; i < np; ++i)
    if (!alive[i]) {
      PieceBuild& o = pieces[std::size_t(owner[i])];
      o.lo = {std::min(o.lo.x, pieces[i].lo.x), std::min(o.lo.y, pieces[i].lo.y), std::min(o.lo.z, pieces[i].lo.z)};
      o.hi = {std::max(o.hi.x, pieces[i].hi.x), std::max(o.hi.y, pieces[i].hi.y), std::max(o.hi.z, pieces[i].hi.z)};
    }
  for (std::size_t t = 0; t < piece_of.tileCount(); ++t)
    for (int k = 0; k < VoxelGrid<int>::kTileVoxels; ++k) {
      std::int32_t& c = piece_of.cell(t, k);
      if (c >= 0) c = owner[std::size_t(c)];
    }

  // 4. Nodes at junctions and ends (and one per pure loop); chains of pieces between them are edges.
  RoadwayGraph g;
  auto index = std::make_shared<FreeSpaceIndex>();
  index->resolution_m = res;
  index->pieces.resize(np);
  for (std::size_t i = 0; i < np; ++i) {
    index->pieces[i].position = pos[i];
    index->pieces[i].lo = pieces[i].lo;
    index->pieces[i].hi = pieces[i].hi;
  }
  auto radiusOf = [&](int p) {
    const PieceBuild& b = pieces[std::size_t(p)];
    double r = 0;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 c = centre({corner & 1 ? b.hi.x : b.lo.x, corner & 2 ? b.hi.y : b.lo.y, corner & 4 ? b.hi.z : b.lo.z}, res);
      r = std::max(r, (c - pos[std::size_t(p)]).norm());
    }
    return r + res;
  };
  auto makeNode = [&](int p) {
    const char* kind = degree[std::size_t(p)] == 1 ? "end-" : degree[std::size_t(p)] >= 3 ? "junction-" : "node-";
    const int id = g.addNode(pos[std::size_t(p)], kind + std::to_string(g.nodes_.size()));
    index->pieces[std::size_t(p)].node = id;
    return id;
  };
  for (std::size_t i = 0; i < np; ++i)
    if (alive[i] && degree[i] != 2) makeNode(int(i));
  // A pure loop (every piece of a part has two neighbours) gets a node at its first piece.
  {
    std::vector<char> reached(np, 0);
    std::vector<int> stack;
    for (std::size_t i = 0; i < np; ++i) {
      if (!alive[i] || reached[i]) continue;
      bool has_node = false;
      int first = int(i);
      stack.assign(1, int(i));
      reached[i] = 1;
      while (!stack.empty()) {
        const int c = stack.back();
        stack.pop_back();
        has_node |= index->pieces[std::size_t(c)].node >= 0;
        first = std::min(first, c);
        for (int n : adj[std::size_t(c)])
          if (alive[std::size_t(n)] && !reached[std::size_t(n)]) reached[std::size_t(n)] = 1, stack.push_back(n);
      }
      if (!has_node) makeNode(first);
    }
  }

  // A voxel path between two touching pieces (breadth-first inside them) where the straight
  // segment between their points loses clearance, e.g. round a bend.
  const double step = 0.5 * res;
  auto voxelPath = [&](int pa, int pb, std::vector<Vec3>* out) {
    const std::vector<Vec3> way = floodPieces(
        piece_of, res, pieces[std::size_t(pa)].best, pieces[std::size_t(pb)].best, true,
        [&](int c) { return c == pa || c == pb; }, [](const VoxelIndex&, const VoxelIndex&) { return true; },
        [](const VoxelIndex&) {});
    if (way.empty()) out->push_back(pos[std::size_t(pb)]);  // cannot happen for touching pieces: straight
    else out->insert(out->end(), way.begin() + 1, way.end());  // its first point is already on the axis
  };
  auto straighten = [&](const std::vector<Vec3>& pts) { return straightenAxis(field, pts, required_clearance_m); };

  std::unordered_set<std::uint64_t> walked;  // directed (piece, next piece) already on an edge
  auto dkey = [](int a, int b) { return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b); };
  for (std::size_t i = 0; i < np; ++i) {
    if (!alive[i] || index->pieces[i].node < 0) continue;
    for (int first : adj[i]) {
      if (!alive[std::size_t(first)] || walked.count(dkey(int(i), first))) continue;
      std::vector<int> chain{int(i)};
      int prev = int(i), cur = first;
      while (true) {
        chain.push_back(cur);
        if (index->pieces[std::size_t(cur)].node >= 0) break;
        const int nx = nextAlive(cur, prev);
        prev = cur;
        cur = nx;
      }
      walked.insert(dkey(int(i), first));
      walked.insert(dkey(chain.back(), chain[chain.size() - 2]));
      auto addChainEdge = [&](const std::vector<int>& part) {
        std::vector<Vec3> pts{pos[std::size_t(part.front())]};
        double radius = 0;
        for (std::size_t c = 0; c < part.size(); ++c) {
          radius = std::max(radius, radiusOf(part[c]));
          if (c == 0) continue;
          const Vec3 a = pos[std::size_t(part[c - 1])], b = pos[std::size_t(part[c])];
          if (segmentClear(field, a, b, required_clearance_m, step)) pts.push_back(b);
          else voxelPath(part[c - 1], part[c], &pts);
        }
        Polyline axis;
        axis.points = straighten(pts);
        const int from = index->pieces[std::size_t(part.front())].node, to = index->pieces[std::size_t(part.back())].node;
        const int e = g.addEdge(from, to, "passage-" + std::to_string(g.edges_.size() + 1), std::move(axis), radius, 0.0);
        index->edge_pieces.push_back(part);
        for (std::size_t c = 1; c + 1 < part.size(); ++c) index->pieces[std::size_t(part[c])].edge = e;
      };
      if (chain.front() == chain.back() && chain.size() >= 5) {
        // A loop back to its own node (a pure loop, or one hanging off a junction): two passages
        // meeting at a node half way round, so that either side can be blocked and routed round.
        const std::size_t half = chain.size() / 2;
        makeNode(chain[half]);
        addChainEdge(std::vector<int>(chain.begin(), chain.begin() + std::ptrdiff_t(half) + 1));
        addChainEdge(std::vector<int>(chain.begin() + std::ptrdiff_t(half), chain.end()));
      } else {
        addChainEdge(chain);
      }
    }
  }
  // A part that is a single piece (a chamber smaller than a slice): one edge from the far end
  // the sweep started at to the voxel farthest from it, so points in it can be routed.
  for (std::size_t i = 0; i < np; ++i) {
    if (!alive[i] || degree[i] != 0) continue;
    const Region& r = regions[std::size_t(pieces[i].region)];
    if (r.root == r.far) continue;
    Polyline axis;
    axis.points = {centre(r.root, res), centre(r.far, res)};
    const int end = g.addNode(axis.points.back(), "end-" + std::to_string(g.nodes_.size()));
    const int e = g.addEdge(index->pieces[i].node, end, "passage-" + std::to_string(g.edges_.size() + 1),
                            std::move(axis), radiusOf(int(i)), 0.0);
    index->edge_pieces.push_back({int(i)});
    index->pieces[i].edge = e;
  }
  // Each inner piece's place along its edge's (straightened) axis.
  for (std::size_t i = 0; i < np; ++i) {
    FreeSpaceIndex::Piece& p = index->pieces[i];
    if (p.edge < 0) continue;
    const Polyline& axis = g.edges_[std::size_t(p.edge)].axis;
    double best = std::numeric_limits<double>::infinity(), arc = 0, at = 0;
    for (std::size_t s = 0; s + 1 < axis.points.size(); ++s) {
      const Vec3 a = axis.points[s], b = axis.points[s + 1];
      const double t = segmentParameter(p.position, a, b);
      const double d = (a + t * (b - a) - p.position).norm();
      if (d < best) best = d, at = arc + t * (b - a).norm();
      arc += (b - a).norm();
    }
    p.arc_m = at;
  }
  index->piece = std::move(piece_of);
  g.info_.voxels = voxels;
  g.info_.regions = regions.size();
  g.info_.pieces = np;
  g.info_.folded_branches = folded;
  g.info_.memory_bytes = index->piece.bytes() + index->pieces.size() * sizeof(FreeSpaceIndex::Piece);
  g.info_.peak_bytes = peak_bytes;
  g.info_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  g.free_space_ = std::move(index);
  progress("free-space graph: done", 1.0);
  return g;
}

// ---- routing and re-checking on the voxels ----

StatusOr<RoadwayGraph::Attachment> RoadwayGraph::attachByVoxel(const Vec3& p, const EdgeFilter& usable) const {
  const FreeSpaceIndex& ix = *free_space_;
  const double res = ix.resolution_m;
  const VoxelIndex v = voxelOf(p, res);
  // The voxel holding p, or the nearest labelled one within two voxels (a start may sit just
  // below the required clearance at its voxel's centre).
  int piece = ix.piece.get(v);
  for (int r = 1; piece < 0 && r <= 2; ++r) {
    double best = std::numeric_limits<double>::infinity();
    for (int z = -r; z <= r; ++z)
      for (int y = -r; y <= r; ++y)
        for (int x = -r; x <= r; ++x) {
          const VoxelIndex w{v.x + x, v.y + y, v.z + z};
          const int c = ix.piece.get(w);
          const double d = (centre(w, res) - p).norm();
          if (c >= 0 && d < best) best = d, piece = c;
        }
  }
  if (piece < 0) return notFound("not in the robot's free space");
  const FreeSpaceIndex::Piece& pc = ix.pieces[std::size_t(piece)];
  std::vector<int> candidates;
  if (pc.edge >= 0) candidates.push_back(pc.edge);
  else if (pc.node >= 0) candidates = incident_[std::size_t(pc.node)];
  Attachment best;
  best.distance = std::numeric_limits<double>::infinity();
  for (int e : candidates) {
    const RoadwayEdge& edge = edges_[std::size_t(e)];
    if (usable && !usable(edge)) continue;
    for (std::size_t i = 0; i + 1 < edge.axis.points.size(); ++i) {
      const Vec3 a = edge.axis.points[i], b = edge.axis.points[i + 1];
      const Vec3 q = a + segmentParameter(p, a, b) * (b - a);
      const double d = (p - q).norm();
      if (d < best.distance) best = {e, i, q, d};
    }
  }
  if (best.edge < 0) return notFound("its passage cannot be used");
  return best;
}

bool RoadwayGraph::refreshFreeSpaceEdge(int edge, const map::DistanceField& field, double required_clearance_m) {
  const FreeSpaceIndex& ix = *free_space_;
  const double res = ix.resolution_m;
  RoadwayEdge& e = edges_[std::size_t(edge)];
  const std::vector<int>& chain = ix.edge_pieces[std::size_t(edge)];
  // Flood fill through the edge's own pieces (both end pieces included) over voxels that still
  // have the clearance, from the point of the end node (its piece's voxel of largest clearance),
  // stepping only where the face between two voxels keeps it too (the planner moves
  // continuously, not from centre to centre). It starts at the node's own voxel, not anywhere in
  // the node's piece: a fall that cuts a junction in two must cut the passages on the far side
  // of it from the node, or a route would cross the junction where no robot can.
  auto position = [&](int piece) {
    for (std::size_t c = 0; c < chain.size(); ++c)
      if (chain[c] == piece) return int(c);
    return -1;
  };
  auto nodeVoxel = [&](int piece) { return voxelOf(ix.pieces[std::size_t(piece)].position, res); };
  auto reach = [&](int start_piece, std::vector<Vec3>* path) {
    std::vector<char> reached(chain.size(), 0);
    const VoxelIndex from = nodeVoxel(start_piece);
    if (field.distance(centre(from, res)) < required_clearance_m) return std::make_pair(reached, false);
    const VoxelIndex target = nodeVoxel(start_piece == chain.front() ? chain.back() : chain.front());
    const auto clear = [&](const Vec3& p) { return field.distance(p) >= required_clearance_m; };
    std::vector<Vec3> found = floodPieces(
        ix.piece, res, from, target, false, [&](int c) { return c >= 0 && position(c) >= 0; },
        [&](const VoxelIndex& v, const VoxelIndex& w) {
          return clear(centre(w, res)) && clear(0.5 * (centre(v, res) + centre(w, res)));
        },
        [&](const VoxelIndex& v) { reached[std::size_t(position(ix.piece.get(v)))] = 1; });
    const bool hit = !found.empty();
    if (path) *path = std::move(found);
    return std::make_pair(reached, hit);
  };
  std::vector<Vec3> way;
  const auto [from_start, passable] = reach(chain.front(), &way);
  e.blocked = !passable;
  if (passable) {
    // Still open, perhaps only round the change (by another part of its pieces): where the axis
    // lost its clearance, it now follows the way the flood found, so that the corridor the
    // planner searches holds a path.
    bool axis_clear = true;
    for (std::size_t i = 0; axis_clear && i + 1 < e.axis.points.size(); ++i)
      axis_clear = segmentClear(field, e.axis.points[i], e.axis.points[i + 1], required_clearance_m, 0.5 * res);
    if (!axis_clear && way.size() >= 2) {
      way.front() = e.axis.points.front();
      way.back() = e.axis.points.back();
      e.axis.points = straightenAxis(field, way, required_clearance_m);
      e.length_m = e.axis.length();
    }
    e.blocked_from_m = e.blocked_to_m = 0.0;
    e.blocked_reason.clear();
    return false;
  }
  const std::vector<char> from_end = reach(chain.back(), nullptr).first;
  auto arcOf = [&](std::size_t c) {
    if (c == 0) return 0.0;
    if (c + 1 == chain.size()) return e.length_m;
    return ix.pieces[std::size_t(chain[c])].arc_m;
  };
  std::size_t first = 0, last = chain.size() - 1;
  while (first < chain.size() && from_start[first]) ++first;
  while (last > 0 && from_end[last]) --last;
  if (first >= chain.size()) first = chain.size() - 1;
  e.blocked_from_m = std::min(arcOf(first), arcOf(last));
  e.blocked_to_m = std::max(arcOf(first), arcOf(last));
  const Vec3 where = ix.pieces[std::size_t(chain[first])].position;
  std::ostringstream m;
  m.precision(1);
  m << std::fixed << "no way through with clearance " << required_clearance_m << " m near (" << where.x() << ", "
    << where.y() << ", " << where.z() << ")";
  e.blocked_reason = m.str();
  return true;
}

std::vector<Vec3> RoadwayGraph::passageSlice(int edge) const {
  std::vector<Vec3> out;
  if (!free_space_ || edge < 0 || std::size_t(edge) >= free_space_->edge_pieces.size()) return out;
  const FreeSpaceIndex& ix = *free_space_;
  const std::vector<int>& chain = ix.edge_pieces[std::size_t(edge)];
  if (chain.size() < 3) return out;  // only its two end pieces: nothing of its own to cut
  const int piece = chain[chain.size() / 2];
  const FreeSpaceIndex::Piece& p = ix.pieces[std::size_t(piece)];
  for (int z = p.lo.z; z <= p.hi.z; ++z)
    for (int y = p.lo.y; y <= p.hi.y; ++y)
      for (int x = p.lo.x; x <= p.hi.x; ++x)
        if (ix.piece.get({x, y, z}) == piece) out.push_back(centre({x, y, z}, ix.resolution_m));
  return out;
}

}  // namespace adit::global
