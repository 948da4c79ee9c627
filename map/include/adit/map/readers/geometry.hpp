// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// What every importer produces: points (a scan) or vertices with triangles (a mesh), in metres,
/// plus an optional sensor viewpoint. The readers only decode and validate; turning geometry into
/// a map (surface voxels, free space) is free_space.hpp's job, so every format is voxelized alike.
///
///   StatusOr<Geometry> g = readGeometry("scan.pcd");     // readers/import.hpp
///   if (g.ok()) std::printf("%zu points\n", g->points.size());

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "adit/map/types.hpp"

namespace adit::map {

struct Geometry {
  std::vector<Vec3> points;  ///< scan points, or the mesh's vertices when `triangles` is not empty
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< indices into `points`
  std::optional<Vec3> viewpoint;                        ///< sensor origin when the file records one
  bool isMesh() const { return !triangles.empty(); }
};

/// Limits every reader checks before allocating: a header that announces more points than this
/// (or than the bytes that follow can hold) is refused with the file and offset/line.
struct ReadLimits {
  std::uint64_t max_points = 500'000'000;
};

namespace readers_internal {
/// "name: message" / "name:line: message" / "name: offset N: message" helpers shared by readers.
std::string at(const std::string& name, std::uint64_t offset);
std::string atLine(const std::string& name, std::uint64_t line);
/// First non-finite point (index) or -1.
std::int64_t firstNonFinite(const std::vector<Vec3>& pts);
}  // namespace readers_internal

}  // namespace adit::map
