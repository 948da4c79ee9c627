// SPDX-License-Identifier: BSD-3-Clause
// PLY bytes (ascii, binary LE/BE; point clouds and meshes) -> parsePly: adit's header checks, then Open3D (points) or Assimp (faces).
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/ply.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parsePly(bytes, "fuzz.ply");
  if (g.ok()) adit::fuzz::checkGeometry(*g);
  return 0;
}
