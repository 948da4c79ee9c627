// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// File input and output every layer shares: a whole file read with a bounded size and a clear
/// error, and the atomic writer behind every file adit writes (maps, plans, pictures, pages,
/// campaign shards). Its own header, so that a reader of a survey, a benchmark map or a robot's
/// token file does not pull in the map loader for one function.
///
///   StatusOr<std::string> text = readFile("district.yaml", 256 << 20);
///   Status s = writeFileAtomically("plan.json", [&](std::ostream& out) { return bool(out << json); });

#include <cstddef>
#include <functional>
#include <ostream>
#include <string>

#include "adit/status.hpp"

namespace adit::map {

/// Calls `write` on a stream to a temporary file beside `path`, then renames it over `path`.
/// If `write` returns false or throws, or the stream fails, the temporary file is removed and
/// `path` is untouched. Writers never destroy what is not theirs:
/// - a symbolic link is followed (through chains and to a dangling target) and its target is
///   replaced, never the link itself; a replaced regular file keeps its permission bits;
/// - a character device (/dev/null, a terminal) or a FIFO is written through in place, without a
///   temporary file (such a write cannot be atomic); block devices and sockets are refused;
/// - SIGINT, SIGTERM or SIGHUP during the write remove the temporary file, then the signal's
///   previous disposition runs (the process still dies of it unless the application handles it).
Status writeFileAtomically(const std::string& path, const std::function<bool(std::ostream&)>& write);

/// Whole file into memory, with a clear error if it is missing, a directory or too large.
StatusOr<std::string> readFile(const std::string& path, std::size_t max_bytes = std::size_t{1} << 32);

}  // namespace adit::map
