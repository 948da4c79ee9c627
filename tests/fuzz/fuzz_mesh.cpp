// SPDX-License-Identifier: BSD-3-Clause
// Mesh bytes -> parseMesh (adit's STL and COLLADA checks, then Assimp), or parsePly for PLY. The
// first byte picks the format (stl, obj, ply, dae), the rest is the file, so one corpus covers
// every mesh format.
// Run with -detect_leaks=0: Assimp leaks inside libassimp on some malformed STL (README.md).
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/mesh.hpp"
#include "adit/map/readers/ply.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* const kHints[] = {"stl", "obj", "ply", "dae"};
  const adit::fuzz::Selected in = adit::fuzz::select(data, size);
  const unsigned format = in.selector % 4;
  // A PLY reaches Assimp only through parsePly, which checks the body first (as adit reads it).
  adit::StatusOr<adit::map::Geometry> g = format == 2 ? adit::map::parsePly(in.bytes, "fuzz.ply")
                                                      : adit::map::parseMesh(in.bytes, "fuzz.mesh", kHints[format]);
  if (g.ok()) {
    adit::fuzz::checkGeometry(*g);
    if (!g->isMesh() && format != 2) adit::fuzz::broken("mesh without triangles");  // a PLY may be a cloud
  }
  return 0;
}
