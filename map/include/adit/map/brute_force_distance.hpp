// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// BruteForceDistance: the oracle. Lists every rock voxel of a (small) map, under its
/// unknown-space policy, and answers distance queries by scanning them all. Tests compare the
/// distance field and the FCL bridge against it; it is far too slow for anything else.
///
///   StatusOr<BruteForceDistance> oracle = BruteForceDistance::create(map);
///   EXPECT_NEAR(field.distance(p), oracle->query(p).distance, 0.5 * map.resolution());
///
/// It keeps a pointer to `map`, which must outlive it.

#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"

namespace adit::map {

class BruteForceDistance {
 public:
  /// Rock voxels are taken from the map's bounds grown by `margin_voxels` (everything beyond is
  /// rock too, but never nearer than that layer). Refuses maps above `max_voxels` voxels.
  static StatusOr<BruteForceDistance> create(const OccupancyMap& map, int margin_voxels = 1,
                                             double max_voxels = 2e7);

  /// Same contract as DistanceField::query: distance to the nearest rock cube surface.
  DistanceSample query(const Vec3& p) const;
  const std::vector<Vec3>& rockCentres() const { return rock_; }
  double resolution() const { return res_; }
  bool isFree(const Vec3& p) const;

 private:
  BruteForceDistance() = default;
  const OccupancyMap* map_ = nullptr;
  double res_ = 0.0;
  std::vector<Vec3> rock_;
};

}  // namespace adit::map
