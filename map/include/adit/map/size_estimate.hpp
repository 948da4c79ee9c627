// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Memory budgets: every reader and every structure built from a map (octree, survey voxels,
/// distance field, top-view footprint) estimates its size first, from counts it can get without
/// building anything, and refuses with a message naming the estimate, the limit and how to proceed
/// (a crop box, a larger --max-memory, a coarser resolution) instead of swapping for minutes or
/// being killed. The estimates are upper bounds within a small factor of the measured peak;
/// each names what it counts.
///
///   MemoryBudget budget{std::uint64_t{4} << 30};
///   ADIT_RETURN_IF_ERROR(budget.check(estimateDistanceField(map).bytes, "the distance field", hint));
///   StatusOr<OccupancyMap> part = cropMap(map, Aabb(lo, hi));

#include <cstdint>
#include <string>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct SurveyNetwork;

/// Default limit of every estimate: 2 GiB (the tools' --max-memory default). The bundled district
/// needs 0.25 GB for a distance query; a larger map asks for more explicitly.
constexpr std::uint64_t kDefaultMaxMemoryBytes = std::uint64_t{2} << 30;

/// The command line's default budget: three quarters of this machine's physical memory, at most
/// 8 GiB (a map of 10^8 voxels plans within it) and at least kDefaultMaxMemoryBytes. A whole
/// 2 km x 1 km district needs about 3 GiB; a laptop's memory still refuses what would swap.
std::uint64_t machineMemoryBudgetBytes();
/// The same, as --max-memory's help says it.
inline constexpr const char* kMachineMemoryBudgetText = "3/4 of this machine's memory, at most 8G";

/// "4G", "512M", "800k", "1.5GiB", "123456" (bytes); binary units (k = 1024). Errors name the text.
StatusOr<std::uint64_t> parseByteSize(const std::string& text);
/// "3.2 GiB", "512.0 MiB", "800 B".
std::string formatBytes(double bytes);

struct MemoryBudget {
  std::uint64_t max_bytes = kDefaultMaxMemoryBytes;
  /// OK when `bytes` fits; else kOutOfRange: "<what> would need about X (limit Y); <how>".
  Status check(double bytes, const std::string& what, const std::string& how) const;
};

/// Bytes an octree of `nodes` nodes takes in OctoMap 1.9.7 (node + children arrays: ~40 B/node).
double estimateOctreeBytes(double nodes);

/// yaml-cpp keeps every scalar as a node of several hundred bytes: a survey file's parse costs
/// far more than the file. Counts the scalar-like tokens in one pass (no parsing).
double estimateSurveyParseBytes(const std::string& yaml_text);

/// Peak bytes of voxelize(): the voxel bit sets plus the octree while it is built (~45 B/voxel).
double estimateVoxelizeBytes(const SurveyNetwork& network);

struct DistanceFieldEstimate {
  std::uint64_t tiles = 0;        ///< 16^3-voxel tiles the field will allocate (exact)
  std::uint64_t index_cells = 0;  ///< cells of its dense tile index
  std::uint64_t cell_tiles = 0;   ///< 8^3-voxel tiles of 4-byte cells within them (exact)
  double bytes = 0.0;
};
/// The tiles DistanceField::build() would allocate for this map under its unknown policy,
/// counted by one walk of the octree without allocating a tile (or, under UnknownPolicy::kFree,
/// from the bounding box, which the field fills). Costs a fraction of a second on the bundled map.
DistanceFieldEstimate estimateDistanceField(const OccupancyMap& map);
/// Bytes per 16^3-voxel distance-field tile at most, while building (16 KiB of cells plus
/// bookkeeping): what bounds the tiles a memory budget allows.
double distanceFieldBytesPerTile();

/// Bytes estimateRoadwayLength() needs for the map's top view (5 bytes per cell).
double estimateFootprintBytes(const OccupancyMap& map);

/// The part of `map` inside `box` (whole voxels whose centre lies in it), same resolution and
/// policy. Refuses an empty or non-finite box, and a box that holds no known voxel.
StatusOr<OccupancyMap> cropMap(const OccupancyMap& map, const Aabb& box);
/// Bytes cropMap() may need (the known voxels inside the box, expanded, ~45 B each).
double estimateCropBytes(const OccupancyMap& map, const Aabb& box);

/// "xmin,ymin,zmin,xmax,ymax,zmax" with finite numbers and min <= max on every axis.
StatusOr<Aabb> parseBox(const std::string& text);

}  // namespace adit::map
