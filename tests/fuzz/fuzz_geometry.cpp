// SPDX-License-Identifier: BSD-3-Clause
// Import bytes -> parseGeometry, the dispatcher `adit map convert` calls: the first byte picks
// the extension, the rest is the file (so the seeds of every format meet every reader).
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/import.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* const kExts[] = {".pcd", ".ply", ".xyz", ".csv", ".las", ".laz", ".stl", ".obj", ".dae", ".bin"};
  const adit::fuzz::Selected in = adit::fuzz::select(data, size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parseGeometry(in.bytes, "fuzz", kExts[in.selector % 10]);
  if (g.ok()) adit::fuzz::checkGeometry(*g);
  return 0;
}
