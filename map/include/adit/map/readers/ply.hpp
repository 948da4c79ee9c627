// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// PLY (ascii, binary little/big endian). The header is checked here (magic, format, element
/// counts against the bytes or lines that follow); a PLY with faces is a mesh and goes through
/// Assimp (readers/mesh.hpp), one without is a point cloud and goes through Open3D.

#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

StatusOr<Geometry> parsePly(const std::string& bytes, const std::string& name, const ReadLimits& limits = {});
StatusOr<Geometry> readPly(const std::string& path, const ReadLimits& limits = {});

}  // namespace adit::map
