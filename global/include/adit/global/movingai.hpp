// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Reader for the MovingAI 3-D voxel benchmark (Brewer & Sturtevant, SoCS 2018): `.3dmap` files
/// (`voxel W H D`, then one blocked voxel `x y z` per line; every other voxel of the box is free)
/// and `.3dscen` files (`version 1`, the map name, then `sx sy sz gx gy gz optimal_cost ratio`,
/// the cost of a 26-connected path without corner cutting). `adit bench global --movingai DIR`
/// measures the global planner against the published optima with it.
///
///   StatusOr<MovingAiMap> m = loadMovingAiMap("A1.3dmap");
///   StatusOr<std::vector<MovingAiProblem>> p = loadMovingAiScenarios("A1.3dmap.3dscen");
///   StatusOr<map::OccupancyMap> crop = movingAiCrop(*m, lo, hi, /*voxel_m=*/1.0);

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"

namespace adit::global {

using VoxelIndex = std::array<int, 3>;

struct MovingAiMap {
  int width = 0, height = 0, depth = 0;  ///< voxels along x, y, z
  std::vector<std::uint64_t> blocked;    ///< bit per voxel, x fastest
  bool isBlocked(int x, int y, int z) const;
};

struct MovingAiProblem {
  VoxelIndex start{}, goal{};
  double optimal_length = 0.0;  ///< in voxels
};

/// Errors name the file and line (bad header, coordinates outside the box, non-numbers).
StatusOr<MovingAiMap> loadMovingAiMap(const std::string& path);
StatusOr<std::vector<MovingAiProblem>> loadMovingAiScenarios(const std::string& path);

/// The voxels [lo, hi) of the map as an OccupancyMap: benchmark voxel (i, j, k) is the cube
/// [i, i+1) x [j, j+1) x [k, k+1) times voxel_m, blocked ones occupied, the rest free; everything
/// outside the crop is unknown (rock). With `subdivision` s > 1 each benchmark voxel becomes s^3
/// map voxels of edge voxel_m / s: the same geometry, so a planner's half-voxel conservative
/// clearance shrinks to 1/(2s) of a benchmark voxel. The benchmark's point agent may stand in any
/// free voxel, even one beside a blocked voxel; s = 3 is the least that lets adit's planner do the
/// same: with an odd s every benchmark voxel's centre is a map voxel's centre, so the roadway graph
/// (built on map voxel centres) also sees passages one benchmark voxel wide. Refuses crops of more
/// than `max_voxels` map voxels.
StatusOr<map::OccupancyMap> movingAiCrop(const MovingAiMap& m, const VoxelIndex& lo, const VoxelIndex& hi,
                                         double voxel_m = 1.0, double max_voxels = 2e7, int subdivision = 1);

/// The smallest box of benchmark voxels [lo, hi) that holds every path from `p.start` to `p.goal`
/// (voxel centres) no longer than its published optimum, plus `pad` voxels on each side: the
/// bounding box of the ellipsoid with those foci and major axis the optimum, clipped to the map.
/// Planning in it loses no path the benchmark's optimum could be, and builds a fraction of the
/// axis-aligned box around the ends grown by half the optimum.
std::pair<VoxelIndex, VoxelIndex> movingAiProblemBox(const MovingAiMap& m, const MovingAiProblem& p, int pad = 2);

}  // namespace adit::global
