// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// PCD point clouds (PCL's format; DATA ascii, binary and binary_compressed). The header is
/// checked here first (fields, sizes, POINTS = WIDTH x HEIGHT, and that the bytes or lines that
/// follow can hold that many points), then Open3D decodes the data; non-finite coordinates are
/// refused with the point's offset or line. A non-default VIEWPOINT becomes Geometry::viewpoint.

#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

/// `name` is used in messages (file name, or a label for bytes that never were a file).
StatusOr<Geometry> parsePcd(const std::string& bytes, const std::string& name, const ReadLimits& limits = {});
StatusOr<Geometry> readPcd(const std::string& path, const ReadLimits& limits = {});

}  // namespace adit::map
