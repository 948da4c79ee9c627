// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// ASPRS LAS 1.0-1.4 point records (formats 0-10; only X, Y, Z are read, scaled and offset as
/// the header says). Hand-written: no Debian package reads LAS for C++ without pulling PDAL.
/// Compressed LAS (LAZ) is refused with "compressed LAS is not supported, decompress it first".
/// Every header field that sizes something is checked against the file before use.

#include <string>

#include "adit/map/readers/geometry.hpp"

namespace adit::map {

StatusOr<Geometry> parseLas(const std::string& bytes, const std::string& name, const ReadLimits& limits = {});
StatusOr<Geometry> readLas(const std::string& path, const ReadLimits& limits = {});

/// The exact message for LAZ input.
inline const char* kLazNotSupported = "compressed LAS is not supported, decompress it first";

}  // namespace adit::map
