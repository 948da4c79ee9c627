// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Triangle meshes of roadway walls (OBJ, STL ascii/binary, PLY with faces, DAE) through Assimp.
/// Assimp triangulates polygons and applies the scene's node transforms; a binary STL's triangle
/// count is checked against the file size first (a header that lies is refused, not trusted),
/// and non-finite vertices are refused with their index.

#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

/// `hint` is the format's extension without the dot ("stl", "obj", "ply", "dae").
StatusOr<Geometry> parseMesh(const std::string& bytes, const std::string& name, const std::string& hint,
                             const ReadLimits& limits = {});
StatusOr<Geometry> readMesh(const std::string& path, const ReadLimits& limits = {});

}  // namespace adit::map
