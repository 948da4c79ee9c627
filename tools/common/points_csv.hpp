// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The point lists of `adit map query`: "x,y,z" on the command line and CSV files of one point per
/// line (a header row, # comments, blank lines, CRLF and a UTF-8 byte-order mark allowed). Every
/// error names the source and line. Kept apart from the verb so the fuzzer can drive the parser.

#include <cstdint>
#include <string>
#include <vector>

#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::tools {

/// "x,y,z" (also ';', tab or blanks between) with finite numbers; `where` prefixes errors.
StatusOr<map::Vec3> parsePoint(const std::string& text, const std::string& where);

/// A whole points CSV already in memory; `name` (the path) prefixes errors as "name:line: ...".
StatusOr<std::vector<map::Vec3>> parsePointsCsv(const std::string& text, const std::string& name);

/// readFile + parsePointsCsv, refused first (with the estimate) when the text and its points
/// would need more than `max_memory_bytes`.
StatusOr<std::vector<map::Vec3>> readPointsCsv(const std::string& path, std::uint64_t max_memory_bytes);

/// Shortest text that reads back to exactly `v` ("1234.5678", "5", "0.1"): query output rows can
/// be joined back to their input.
std::string roundTripNumber(double v);

}  // namespace adit::tools
