// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What a free-space roadway graph keeps of its construction: every voxel of the robot's free
// configuration space labelled with the piece (a slice of a passage) it belongs to, and each
// piece's place in the graph. Routing uses it to put a start or goal on the passage that really
// holds it (not the nearest axis, which may be behind a thin wall), and refreshBlocked() to
// re-check a passage exactly, by flood fill through its own voxels, after the map changes.
#include <cstdint>
#include <vector>

#include "voxel_grid.hpp"

namespace adit::global {

struct FreeSpaceIndex {
  struct Piece {
    map::Vec3 position = map::Vec3::Zero();  ///< its voxel of largest clearance
    VoxelIndex lo, hi;                        ///< voxel bounding box
    int node = -1;                            ///< graph node it is (junction, end), or -1
    int edge = -1;                            ///< graph edge it lies inside, or -1
    double arc_m = 0.0;                       ///< along that edge's axis
  };
  double resolution_m = 0.0;
  VoxelGrid<std::int32_t> piece;  ///< voxel -> piece, -1 outside the configuration space
  std::vector<Piece> pieces;
  std::vector<std::vector<int>> edge_pieces;  ///< per edge: its pieces from `from` to `to`, both node pieces included
};

}  // namespace adit::global
