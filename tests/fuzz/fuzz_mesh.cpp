// SPDX-License-Identifier: BSD-3-Clause
// Mesh bytes -> parseMesh (adit's STL size check, then Assimp). The first byte picks the format
// hint (stl, obj, ply, dae), the rest is the file, so one corpus covers every mesh format.
// Run with -detect_leaks=0: Assimp leaks inside libassimp on some malformed STL (README.md).
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/mesh.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* const kHints[] = {"stl", "obj", "ply", "dae"};
  const adit::fuzz::Selected in = adit::fuzz::select(data, size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parseMesh(in.bytes, "fuzz.mesh", kHints[in.selector % 4]);
  if (g.ok()) {
    adit::fuzz::checkGeometry(*g);
    if (!g->isMesh()) adit::fuzz::broken("mesh without triangles");
  }
  return 0;
}
