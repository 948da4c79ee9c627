// SPDX-License-Identifier: BSD-3-Clause
// Text point cloud bytes (XYZ/CSV/TXT/PTS) -> parseXyz, adit's own line parser.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/xyz.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parseXyz(bytes, "fuzz.xyz");
  if (g.ok()) adit::fuzz::checkGeometry(*g);
  return 0;
}
