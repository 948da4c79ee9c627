// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Every rock surface point within a radius, written into a buffer the caller owns: what the
/// field-of-view and VFF-style repulsions of the local layer sum over (the DistanceField gives
/// only the nearest rock). A rock voxel is on the surface when one of its 6 neighbours is free;
/// for each such voxel whose cube comes within `radius` of the centre, the query writes the point
/// of the cube nearest to the centre. It never allocates, so the per-period local step may call it.
///
///   std::array<Vec3, 512> buf;
///   RockPointsResult r = rockSurfacePoints(field, robot, 2.0, buf.data(), buf.size());
///   for (std::size_t i = 0; i < r.written; ++i) repel(buf[i]);
///   if (r.truncated) warn();   // more points than the buffer holds

#include <cstddef>

#include "adit/map/distance_field.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct RockPointsResult {
  std::size_t written = 0;  ///< points written to the buffer
  std::size_t found = 0;    ///< surface points within the radius (> written when truncated)
  bool truncated = false;   ///< the buffer was too small, or the window too large (see below)
};

/// Rock surface points within `radius` of `centre` (distance from the centre to the voxel cube).
/// Order: by voxel, z-major then y then x. The scan visits at most `max_window_voxels` voxels;
/// a larger window (or a non-finite centre or radius) writes nothing and sets truncated.
/// Voxels nearer to the centre than its distance-field clearance are known free and skipped.
RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, Vec3* out,
                                   std::size_t capacity, std::size_t max_window_voxels = 1u << 18) noexcept;

/// A cone about `axis` (unit or zero = no cone) with half opening `half_angle_rad`.
struct ViewCone {
  Vec3 axis = Vec3::Zero();
  double half_angle_rad = 3.14159265358979323846;
};
/// The same, only the points inside the cone (a field of view): voxels outside are not read.
RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, const ViewCone& cone,
                                   Vec3* out, std::size_t capacity,
                                   std::size_t max_window_voxels = 1u << 18) noexcept;

}  // namespace adit::map
