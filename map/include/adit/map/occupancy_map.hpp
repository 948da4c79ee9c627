// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// OccupancyMap: the mine as an OctoMap octree with an explicit policy for unknown space.
/// In a surveyed mine everything that nobody surveyed or scanned is rock, so the default policy is
/// UnknownPolicy::kRock; FCL and OMPL would silently treat it as free. OctoMap keys are 16-bit, so
/// a map spans at most +-32768 voxels from the origin on each axis (+-3.3 km at 0.1 m): maps that
/// do not fit are refused, never wrapped.
///
///   StatusOr<OccupancyMap> map = loadMap("maps/district.bt");
///   if (map.ok() && map->isFree({10, 0, 1.5})) { ... }
///   MapStats s = map->stats();   // bounds, voxel counts, volumes

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "adit/status.hpp"
#include "adit/map/types.hpp"

namespace octomap {
class OcTree;
class OcTreeKey;
}

namespace adit::map {

enum class VoxelState : std::uint8_t { kFree = 0, kOccupied = 1, kUnknown = 2 };
const char* voxelStateName(VoxelState s);

/// How unknown voxels (never observed, or outside the map) count for planning.
enum class UnknownPolicy {
  kRock,  ///< unknown is rock: the right default for a surveyed mine
  kFree,  ///< unknown inside the map bounds is free (e.g. a partly scanned building)
};
const char* unknownPolicyName(UnknownPolicy p);
StatusOr<UnknownPolicy> parseUnknownPolicy(const std::string& name);

/// Summary of a map. Voxel counts are at the finest resolution (a pruned leaf counts 8^k voxels);
/// unknown = voxels of the bounding box that are neither free nor occupied.
struct MapStats {
  double resolution_m = 0.0;
  Aabb bounds;                   ///< of every known (free or occupied) voxel
  std::uint64_t free_voxels = 0;
  std::uint64_t occupied_voxels = 0;
  std::uint64_t unknown_voxels = 0;
  std::uint64_t octree_nodes = 0;
  double voxelVolume() const { return resolution_m * resolution_m * resolution_m; }
};

/// Largest coordinate magnitude a map of this resolution can hold (OctoMap's 16-bit keys).
double maxMapExtent(double resolution_m);
/// OK when `box` fits OctoMap's key range at `resolution_m`; the error names the offending corner.
Status checkExtent(const Aabb& box, double resolution_m);
/// OK for a finite resolution > 0 (and >= 1 mm, below which float keys stop being meaningful).
Status checkResolution(double resolution_m);

/// What one map update changed: the voxels whose state differs afterwards (re-marking a voxel
/// with the state it had is no change). Hand `box` to DistanceField::update().
struct MapChange {
  Aabb box;                        ///< union of the changed voxels' cubes; empty when nothing changed
  std::size_t to_occupied = 0;     ///< voxels that became occupied
  std::size_t to_free = 0;         ///< voxels that became free
  std::size_t to_unknown = 0;      ///< voxels that were deleted (set to unknown)
  std::size_t changed() const { return to_occupied + to_free + to_unknown; }
  bool empty() const { return changed() == 0; }
};

/// Copies share the octree (it can be hundreds of megabytes): setVoxels() on one copy changes
/// what every copy sees, though only its own statistics. Keep one owner that mutates the map.
/// A deepCopy() keeps its writes beside the octree it shares, so that a navigator's belief costs
/// the voxels it changed, not a clone of millions of nodes (see deepCopy()).
class OccupancyMap {
 public:
  /// Wraps `tree` (taken over). Refuses an invalid resolution and a map without free space under
  /// the chosen policy ("empty map").
  static StatusOr<OccupancyMap> create(std::shared_ptr<octomap::OcTree> tree,
                                       UnknownPolicy policy = UnknownPolicy::kRock);
  /// A map from voxel centres (e.g. a benchmark grid), for callers that have no octree of their
  /// own; later points win where two fall in one voxel. Refuses a bad resolution, non-finite
  /// points, points off OctoMap's key range, and an empty map, like create().
  static StatusOr<OccupancyMap> fromVoxels(double resolution_m, const std::vector<Vec3>& free,
                                           const std::vector<Vec3>& occupied,
                                           UnknownPolicy policy = UnknownPolicy::kRock);

  double resolution() const;
  UnknownPolicy unknownPolicy() const { return policy_; }
  /// The same octree seen under another policy (shares the tree).
  OccupancyMap withUnknownPolicy(UnknownPolicy policy) const;
  /// A copy that behaves as one with its own octree, for a second owner that mutates it: e.g.
  /// each simulated run's believed map, made from one loaded map instead of voxelizing the survey
  /// again per run. Its writes (setVoxels, insertRays) are kept as an overlay of changed voxels
  /// over the original's octree, which it shares and never writes: cloning and freeing millions of
  /// nodes was a fifth of a campaign's time, and a run changes a few thousand voxels. Voxel
  /// queries (state, isFree, lineOfSight) read the overlay first. What needs the whole tree
  /// (octree(), sharedOctree(), forEachLeaf) gets, from the first such call on, a clone with the
  /// overlay applied, which later writes then go to; so does a copy whose overlay outgrows
  /// kMaxOverlayVoxels. The original must not be written while copies read it (one owner writes).
  /// Plain copies of the copy share its overlay; its stats' octree_nodes count the shared octree's
  /// nodes plus the overlay's voxels until the clone is made.
  OccupancyMap deepCopy() const;
  /// Changed voxels a deepCopy() holds beside the shared octree before cloning it (about 50 MB).
  static constexpr std::size_t kMaxOverlayVoxels = std::size_t{1} << 20;

  /// Raw state of the voxel holding `p`; outside the key range it is kUnknown.
  VoxelState state(const Vec3& p) const;
  /// Free under the unknown-space policy. Outside the known bounds is always rock: adit never
  /// plans off the map; so is the outermost voxel layer of the key range.
  bool isFree(const Vec3& p) const;
  bool isRock(const Vec3& p) const { return !isFree(p); }

  Aabb bounds() const { return stats_.bounds; }
  const MapStats& stats() const { return stats_; }

  /// Visits every leaf: centre, edge length, and raw state (kFree or kOccupied).
  void forEachLeaf(const std::function<void(const Vec3& center, double size, VoxelState state)>& fn) const;

  /// Marks the voxel holding `p` occupied or free (e.g. sensed rubble); call
  /// DistanceField::update() over the changed window afterwards. Refuses points off the key range.
  Status setVoxel(const Vec3& p, VoxelState state) { return setVoxels({p}, state); }
  /// Batch form: all points are checked first, so a refused batch changes nothing. Statistics
  /// are updated incrementally; the bounds only grow.
  Status setVoxels(const std::vector<Vec3>& points, VoxelState state);
  /// The same, reporting what changed (`change` may be null).
  Status setVoxels(const std::vector<Vec3>& points, VoxelState state, MapChange* change);
  /// A range sensor's scan as one transaction: every voxel a ray crosses from `origin` toward a
  /// return becomes free, the return's voxel occupied (a voxel that is some ray's return stays
  /// occupied even if another ray crosses it). Returns farther than `max_range_m` are rays with no
  /// return: free up to the range, nothing occupied. Unlike setVoxels() this clears what the
  /// sensor saw through: rubble the map still holds but the rays pass becomes free again. The
  /// caller must only give returns the sensor actually saw (a ray through rock would carve the
  /// map). Refuses, changing nothing, a non-finite origin or return, a range <= 0, or a ray
  /// leaving OctoMap's key range.
  StatusOr<MapChange> insertRays(const Vec3& origin, const std::vector<Vec3>& returns, double max_range_m);
  /// Line of sight for a simulated range sensor: visible[i] is 1 when every voxel the segment
  /// origin → targets[i] crosses before the target's own voxel is free (the voxels insertRays()
  /// would clear), else 0. Targets off the key range or non-finite are not visible. `opaque`, if
  /// given, marks more voxels (by centre) that block sight, e.g. rock the map does not hold yet.
  void lineOfSight(const Vec3& origin, const std::vector<Vec3>& targets, std::vector<char>& visible,
                   const std::function<bool(const Vec3&)>& opaque = {}) const;

  /// A map read from the map cache holds its octree as bytes until something needs the nodes:
  /// building 2.6 million nodes is most of a cached load, and planning reads the field only.
  /// These (and every query above but resolution() and stats()) build it on first use.
  const octomap::OcTree& octree() const { return tree(); }
  std::shared_ptr<const octomap::OcTree> sharedOctree() const;
  /// Voxel queries (state, isFree, lineOfSight, writes) on a map read from the cache answer from
  /// the voxels' states, read from the same bytes on the first query (3.8 MB for the
  /// district, whose 2.6 million nodes take about 100 MB), not from the octree. This reads them now:
  /// before forking workers that all query the map, so that they share one copy.
  void prepareVoxelQueries() const;

 private:
  friend struct MapCacheIo;
  struct LazyTree;
  OccupancyMap(std::shared_ptr<octomap::OcTree> tree, UnknownPolicy policy);
  // A map whose octree is OcTree::writeData's stream `data`, built on first use; `stats` are
  // the built map's (the cache checked both).
  static OccupancyMap fromOctreeData(std::string data, UnknownPolicy policy, const MapStats& stats);
  struct Overlay;
  // The tree whole-tree readers and writers use: for a deepCopy(), its clone (made on first use).
  octomap::OcTree& tree() const;
  // The octree this map was made on (for a deepCopy(), the original's): keys, rays, lookups.
  octomap::OcTree& base() const { return tree_ ? *tree_ : lazyTree(); }
  octomap::OcTree& lazyTree() const;
  // Key arithmetic (the same for the built tree and an empty one of its resolution).
  const octomap::OcTree& keys() const;
  // The original tree's state of a voxel and its node count, without building a lazy tree.
  VoxelState baseState(const octomap::OcTreeKey& key) const;
  std::uint64_t baseNodes() const;
  VoxelState keyState(const octomap::OcTreeKey& key) const;
  void recomputeStats();
  void applyKey(const octomap::OcTreeKey& key, VoxelState state, MapChange& change);
  void finishUpdate();
  void prepareWrite();

  std::shared_ptr<octomap::OcTree> tree_;  // null while lazy_ holds the octree as bytes
  std::shared_ptr<LazyTree> lazy_;
  std::shared_ptr<Overlay> overlay_;  // a deepCopy()'s writes; null for a map that writes its tree
  UnknownPolicy policy_ = UnknownPolicy::kRock;
  MapStats stats_;
};

}  // namespace adit::map
