// SPDX-License-Identifier: BSD-3-Clause
// PCD point cloud bytes (ascii, binary, binary_compressed) -> parsePcd: adit's header checks, then Open3D's decoder.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/pcd.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parsePcd(bytes, "fuzz.pcd");
  if (g.ok()) adit::fuzz::checkGeometry(*g);
  return 0;
}
