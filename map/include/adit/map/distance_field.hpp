// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// DistanceField: for any point, the Euclidean distance to the nearest rock voxel (occupied, or
/// unknown under UnknownPolicy::kRock), the closest point on it, and the gradient "away from
/// rock". It is what the planners' hot loops call instead of FCL. The transform is exact (every
/// voxel centre knows its nearest rock voxel); a query at an arbitrary point is an upper bound
/// that the tests hold within half a voxel of brute force (0.2 voxel measured). Callers that need
/// a conservative clearance subtract half a voxel, or ask CollisionChecker.
///
/// Algorithm: an exact separable Euclidean feature transform (Felzenszwalb-Huttenlocher lower
/// envelopes, one pass per axis) over sparse 4^3 tiles, indexed by a dense grid of 16^3 blocks.
/// Only tiles that hold free voxels are allocated; everything else is rock, so a 2 km x 1 km
/// district costs memory in proportion to its roadways, not its bounding box. Each free voxel
/// stores the offset to its nearest rock voxel in 4 bytes (sites beyond +-255 voxels on an axis
/// are kept exactly in a side table), about 6 bytes per free voxel in all; a query reads the 8
/// voxels around the point and returns the distance from the point to the nearest of their rock
/// voxels, measured to the voxel's surface (a cube of edge `res`).
///
/// Conventions: the field is unsigned. Inside rock the distance is 0 and the gradient is zero.
/// Outside the map's key range everything is rock.
///
///   StatusOr<DistanceField> df = DistanceField::build(map);
///   DistanceSample s = df->query({10.0, 2.0, 1.5});
///   if (s.distance < 0.5) push_away(s.gradient);
///   map.setVoxels(rubble, VoxelState::kOccupied);
///   df->update(map, rubble_box);   // exact again, in a fraction of a full build

#include <cstdint>
#include <memory>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct DistanceSample {
  double distance = 0.0;      ///< to the nearest rock surface [m]; 0 inside rock
  Vec3 gradient = Vec3::Zero();  ///< unit, away from the nearest rock; zero inside rock
  Vec3 nearest = Vec3::Zero();   ///< closest point on the nearest rock voxel
  bool in_rock = true;
};

struct DistanceFieldStats {
  std::uint64_t free_voxels = 0;
  std::uint64_t blocks = 0;             ///< 16^3 blocks that hold free space (the index's regions)
  std::uint64_t index_entries = 0;      ///< dense block index cells (4 bytes each)
  std::uint64_t memory_bytes = 0;       ///< tiles + index + far table
  double build_seconds = 0.0;          ///< whole build: reading the octree + transform
  double transform_seconds = 0.0;      ///< the Euclidean transform alone
  double max_distance_m = 0.0;          ///< largest clearance in the map
  std::uint64_t tiles = 0;              ///< allocated tiles of tile_edge_voxels^3 voxels, 4 bytes a voxel
  std::uint64_t tile_edge_voxels = 0;
  std::uint64_t far_sites = 0;          ///< free voxels whose nearest rock is beyond the cell's offset range
  double bytesPerFreeVoxel() const { return free_voxels ? double(memory_bytes) / double(free_voxels) : 0.0; }
  /// Voxels processed per second (blocks x 4096 / time), whole build or transform only.
  double voxelsPerSecond() const { return build_seconds > 0 ? double(blocks) * 4096.0 / build_seconds : 0.0; }
  double transformVoxelsPerSecond() const {
    return transform_seconds > 0 ? double(blocks) * 4096.0 / transform_seconds : 0.0;
  }
};

/// What DistanceField::update() recomputed (the navigator reports it per map transaction).
struct DistanceFieldUpdateReport {
  bool full_rebuild = false;     ///< the window was too large: the field was rebuilt from the map
  bool full_transform = false;   ///< the transform ran over every tile (window grew to most of the map)
  Aabb recomputed;               ///< the box whose transform was recomputed (world coordinates)
  std::uint64_t voxels_recomputed = 0;  ///< voxels in that box
  double seconds = 0.0;
};

class DistanceField;

/// What one reader of a DistanceField read last, so that it can read the same voxels again
/// without looking them up: a cost integral differentiated numerically samples each segment again
/// and again with one end moved by a finite-difference step, and nearly every sample falls among
/// the same 8 voxels as before. DistanceField::distance(p, cache) is distance(p) bit for bit; the
/// cache forgets what it holds when the field's generation() changes (an update(), another
/// field). One per thread: reading through it writes it. About 46 KiB, allocated here.
class DistanceReadCache {
 public:
  DistanceReadCache();
  /// Reads answered from the cache and reads that looked the voxels up (and were kept).
  std::uint64_t hits() const noexcept { return hits_; }
  std::uint64_t misses() const noexcept { return misses_; }

 private:
  friend class DistanceField;
  static constexpr int kSlotBits = 10;
  // The 8 voxels' cells around one base voxel, as the field stores them.
  struct Slot {
    std::int32_t key[3];
    std::uint32_t cells[8];
  };
  void reset(std::uint64_t generation) noexcept;
  std::unique_ptr<Slot[]> slots_;
  std::uint64_t generation_ = 0;  // of the field the slots were read from; 0: none
  std::uint64_t hits_ = 0, misses_ = 0;
};

class DistanceField {
 public:
  /// Builds the field from the map under its unknown-space policy. Refuses maps whose free space
  /// would need more than `max_blocks` blocks of 16^3 voxels (at most 16 KiB each).
  static StatusOr<DistanceField> build(const OccupancyMap& map, const ProgressFn& progress = {},
                                       std::uint64_t max_blocks = 1u << 20);

  /// For tests only: build(map), with the sites a cell holds as an offset cut to `max_offset`
  /// voxels per axis (instead of 255), so that the far table, which only clearances of tens of
  /// metres reach, is exercised on small maps. Exactness does not depend on the limit.
  static StatusOr<DistanceField> buildWithNearLimitForTesting(const OccupancyMap& map, int max_offset);

  DistanceField(DistanceField&&) noexcept;
  DistanceField& operator=(DistanceField&&) noexcept;
  DistanceField(const DistanceField&);
  DistanceField& operator=(const DistanceField&);
  ~DistanceField();

  /// Distance, gradient and closest rock point. Never throws; NaN input gives in_rock = true.
  DistanceSample query(const Vec3& p) const noexcept;
  /// query(p).distance, bit for bit, without the gradient and closest point (a cost integral's
  /// samples need only this).
  double distance(const Vec3& p) const noexcept;
  /// distance(p), bit for bit, reading the 8 voxels around p from `cache` when it read them
  /// before from this content of the field (see DistanceReadCache).
  double distance(const Vec3& p, DistanceReadCache& cache) const noexcept;
  /// How far distance(p) may exceed the true distance to rock, proven rather than measured: the
  /// voxel holding p (centre c, |p - c| <= sqrt(3)/2 voxel) is one of the 8 read, and its stored
  /// site S is at least as near c as the centre of p's truly nearest rock voxel R, so
  /// distance(p) <= |p - S| <= 2 |p - c| + |p - R| <= true + 3 sqrt(3)/2 voxels (|p - R| exceeds
  /// the distance to R's cube by at most sqrt(3)/2 voxel). With the true distance 1-Lipschitz,
  /// distance(q) >= distance(p) - |p - q| - errorBound(): a scan along a segment may skip every
  /// sample that this proves clear.
  double errorBound() const noexcept { return 2.598076211353316 * resolution(); }
  /// Free under the policy the field was built with (the voxel holding p).
  bool isFree(const Vec3& p) const noexcept;
  /// isFree() of a whole box of voxels, read a tile row at a time: out[i + n[0] (j + n[1] k)] is
  /// 1 for the free voxel (lo[0] + i, lo[1] + j, lo[2] + k), the voxel of index v along an axis
  /// being [v, v + 1) times the resolution, else 0. A search that reads most of a small window
  /// (the surface rock around a robot) pays one tile lookup per row of a tile, not one per voxel.
  void freeVoxels(const std::int64_t lo[3], const std::int64_t n[3], std::uint8_t* out) const noexcept;
  /// Centre of the nearest rock voxel to the voxel holding p (the stored feature transform).
  Vec3 nearestRockVoxel(const Vec3& p) const noexcept;
  /// Distance from the centre of the voxel holding p to the centre of its nearest rock voxel
  /// (the stored transform, exact): every voxel whose centre is nearer than that is free, so a
  /// scan along a line of voxel centres may skip them. 0 when the voxel is rock; one voxel's
  /// edge where the transform holds no site (only the voxel itself is then known free).
  double voxelClearance(const Vec3& p) const noexcept;

  /// Re-reads the voxels inside `changed` from `map` (after OccupancyMap::setVoxels) and makes
  /// the field exact again by recomputing the transform over `changed` grown by the largest
  /// clearance, with a margin that doubles until every result is provably exact.
  Status update(const OccupancyMap& map, const Aabb& changed);
  /// The same, saying what it recomputed (`report` may be null).
  Status update(const OccupancyMap& map, const Aabb& changed, DistanceFieldUpdateReport* report);

  double resolution() const;
  const DistanceFieldStats& stats() const;
  /// Names this content of the field: a new value after every build and update() (process-wide,
  /// so no two contents share one); a copy keeps its original's. Callers that keep what they read
  /// (the local planner's band cache) drop it when the generation changes.
  std::uint64_t generation() const noexcept;

 private:
  friend struct MapCacheIo;
  struct Impl;
  explicit DistanceField(std::unique_ptr<Impl> impl);
  // query()'s work; with full = false only the distance is filled in; with a cache, the 8 cells
  // are read through it.
  DistanceSample sample(const Vec3& p, bool full, DistanceReadCache* cache) const noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace adit::map
