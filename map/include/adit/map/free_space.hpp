// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Imported geometry (a registered scan or a mesh of the roadway walls) becomes a navigable map:
/// the surface becomes occupied voxels, and the free inside of the roadways is recovered either by
/// casting rays from the scanner trajectory to the points it saw, or by a flood fill from a seed
/// point the user names or the import chooses (`auto_seed`). Scans have holes and open ends, so the flood is bounded three ways:
///  - it stays within `max_wall_distance_m` (Chebyshev) of the scanned surface,
///  - an optional morphological closing of the surface (radius `closing_radius_m`) plugs holes
///    narrower than twice the radius before filling,
///  - a voxel may be filled only if it lies inside the scan's hull: scanned surface above and below
///    it in its column (`hull_cell_m` thick). Outside a roadway wall, beyond an open end, under a
///    holed floor or over a holed roof that test fails, so free space cannot run round the outside.
/// Everything not recovered stays unknown, i.e. rock under adit's default policy. The input's
/// bounding box is the grid: nothing is ever filled outside it.
/// Last, thin rock is cleared: a sparse or merged scan leaves single occupied voxels in the open
/// roadway and on its walls (noise points, cables, scanner artefacts) that cut the robot's free
/// space into pieces although the roadway is open. A scanned voxel that lies in no all-rock cube
/// of edge `thin_radius_m` + one voxel (a morphological opening of the rock, which counts the
/// unknown beyond the walls) and that borders free space, directly or through other such voxels,
/// becomes free. Walls backed by rock, and pillars thicker than the radius, are never touched.
///
///   ImportParams p;
///   p.resolution_m = 0.2;
///   p.seed = Vec3(10, 0, 1.5);
///   StatusOr<ImportResult> r = buildMapFromGeometry(geometry, p);

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/readers/geometry.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct ImportParams {
  double resolution_m = 0.2;
  std::optional<Vec3> seed;     ///< flood-fill start inside a roadway
  /// Without seed or trajectory: choose the seed. The interior cell farthest from the scanned
  /// surface (up to max_wall_distance_m) among those with scanned surface straight above and below
  /// and walls on both sides along x or along y, each within max_wall_distance_m: a roadway's
  /// inside, not the rock between two scanned levels (no walls beside it) nor the space outside a
  /// wall (no roof over it). Reported in ImportResult::seed.
  bool auto_seed = false;
  /// How errors name the seed, e.g. as the user typed it in the input's frame when the geometry
  /// was shifted (UTM) or turned (Y up); empty: its coordinates as given here.
  std::string seed_name;
  std::vector<Vec3> trajectory;  ///< scanner positions: rays from the nearest one to each point
  double max_wall_distance_m = 5.0;  ///< flood only this close to the surface (also bounds memory)
  double closing_radius_m = 0.0;     ///< plug holes narrower than 2 r before flooding (0: off)
  /// The hull test looks at lines this thick (rounded to voxels, at least one): a sparse scan
  /// has single voxel columns without a floor point. Free space may reach up to this far past a
  /// wall gap; coarser is more forgiving of sparse scans, finer is tighter.
  double hull_cell_m = 0.0;
  double max_ray_m = 60.0;           ///< rays longer than this (point to nearest pose) are skipped
  /// Clear scanned rock no thicker than this [m] where it borders free space (unset: one voxel,
  /// i.e. single-voxel speckle, lines and sheets; 0: off). At most 16 voxels.
  std::optional<double> thin_radius_m;
  std::uint64_t max_memory_bytes = std::uint64_t{4} << 30;  ///< working grid budget
  UnknownPolicy unknown_policy = UnknownPolicy::kRock;
  Status validate() const;
};

enum class FreeSpaceSource { kSeedFlood, kTrajectoryRays };
const char* freeSpaceSourceName(FreeSpaceSource s);

struct ImportResult {
  OccupancyMap map;
  FreeSpaceSource source = FreeSpaceSource::kSeedFlood;
  std::uint64_t inputs = 0;           ///< points, or triangles for a mesh
  std::uint64_t surface_voxels = 0;   ///< occupied: the scanned surface
  std::uint64_t closed_voxels = 0;    ///< occupied: holes plugged by the closing
  std::uint64_t free_voxels = 0;      ///< including the thin rock cleared
  std::uint64_t thin_cleared = 0;     ///< scanned voxels cleared as thin rock (speckle, cables)
  std::uint64_t working_bytes = 0;    ///< peak size of the working grid (and the thin-rock work list)
  std::optional<Vec3> seed;           ///< the flood's seed (given or chosen), centre of its voxel if chosen
};

/// The whole import: surface voxels, free-space recovery, octree. One of seed, trajectory or
/// auto_seed must be given (a trajectory wins, then a seed). Errors name the seed and why it cannot start
/// (on the surface, outside the hull, too far from any wall), or the memory estimate.
StatusOr<ImportResult> buildMapFromGeometry(const Geometry& geometry, const ImportParams& params,
                                            const ProgressFn& progress = {});

/// OctoMap keys of the voxels holding the points (deduplicated, unordered): the import's first
/// stage, benchmarked on its own. The caller checks the points fit the key range.
using VoxelKey = std::array<std::uint16_t, 3>;
std::vector<VoxelKey> occupiedVoxelKeys(const std::vector<Vec3>& points, double resolution_m);

/// Same for a mesh: triangles sampled finely enough (< res/2 apart) that no voxel they cross is
/// missed. Refuses meshes whose sampling would exceed `max_samples`.
StatusOr<std::vector<VoxelKey>> meshVoxelKeys(const Geometry& mesh, double resolution_m,
                                              std::uint64_t max_samples = 2'000'000'000);

}  // namespace adit::map
