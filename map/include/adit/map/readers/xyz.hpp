// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Text point clouds: XYZ / CSV / TXT / PTS, one point per line, the first three numbers are
/// x, y, z (more columns such as intensity or colour are ignored), separated by spaces, tabs,
/// commas or semicolons. One header row and '#' comments are allowed; a UTF-8 BOM is skipped.
/// Hand-written because Open3D's xyz reader silently skips lines it cannot parse and reads no
/// CSV; here every bad line is an error naming the line.

#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

StatusOr<Geometry> parseXyz(const std::string& bytes, const std::string& name, const ReadLimits& limits = {});
StatusOr<Geometry> readXyz(const std::string& path, const ReadLimits& limits = {});

}  // namespace adit::map
