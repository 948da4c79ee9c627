// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// One entry for every import format, chosen by extension: point clouds (.pcd, .ply, .xyz, .csv,
/// .txt, .pts, .las; .laz is refused), meshes (.stl, .obj, .dae; .ply with faces). Also the frame
/// fixes `adit map convert` applies before voxelizing: Y-up to Z-up, and an origin shift for
/// survey grids far from 0 (UTM), and the scanner-trajectory CSV.
///
///   StatusOr<Geometry> g = readGeometry("mine.stl");
///   toMapFrame(&*g, /*y_up=*/true, origin);

#include <optional>
#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

/// True for an extension readGeometry() handles.
bool isImportFormat(const std::string& path);
/// Parses bytes as the format of extension `ext` (".pcd", ...); `name` is used in messages.
StatusOr<Geometry> parseGeometry(const std::string& bytes, const std::string& name, const std::string& ext,
                                 const ReadLimits& limits = {});
StatusOr<Geometry> readGeometry(const std::string& path, const ReadLimits& limits = {});

/// Input frame -> map frame: with `y_up`, (x, y, z) -> (x, -z, y); then minus `origin`.
Vec3 toMapFrame(const Vec3& p, bool y_up, const Vec3& origin);
void toMapFrame(Geometry* g, bool y_up, const Vec3& origin);

/// The origin to subtract: `requested` if given; otherwise zero when the (already Y-up-fixed)
/// box fits OctoMap's keys at `resolution_m` and lies within 10 km of zero (float precision),
/// else the box centre rounded to whole metres. `automatic` tells the caller to record it.
Vec3 chooseOrigin(const Aabb& box, double resolution_m, const std::optional<Vec3>& requested, bool* automatic);

/// Scanner poses, one per line: "x,y,z", "x y z qx qy qz qw" (7 columns) or TUM's
/// "t x y z qx qy qz qw" (8 columns); or any columns under a header row naming x, y and z.
StatusOr<std::vector<Vec3>> parseTrajectory(const std::string& bytes, const std::string& name);
StatusOr<std::vector<Vec3>> readTrajectory(const std::string& path);

}  // namespace adit::map
