// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Figures a mine engineer checks first: the roadway length of a map. A survey network knows its
/// centrelines; an octree (a .bt from a scan or another tool) does not, so its length is
/// estimated from the top-view footprint of the free space: every footprint cell contributes its
/// area divided by the local roadway width, the shortest run of free cells through it in four
/// directions (0, 45, 90, 135 degrees; at most 8 % too wide for any heading). For a straight
/// roadway this is length x width / width; junctions count once.
///
///   RoadwayLengthEstimate e = estimateRoadwayLength(map);
///   std::cout << e.length_m << " m (median width " << e.median_width_m << " m)\n";

#include "adit/map/occupancy_map.hpp"

namespace adit::map {

struct RoadwayLengthEstimate {
  double length_m = 0.0;
  double footprint_area_m2 = 0.0;  ///< top-view area with any free voxel
  double median_width_m = 0.0;     ///< median of the per-cell widths
};

/// Refuses maps whose top view exceeds `max_cells` cells (1 byte each, plus 4 per direction pass).
StatusOr<RoadwayLengthEstimate> estimateRoadwayLength(const OccupancyMap& map, double max_cells = 4e8);

}  // namespace adit::map
