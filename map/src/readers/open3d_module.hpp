// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The Open3D decoders (PCD and PLY clouds, PNG images) as a module that adit_map loads on first use
// (open3dModule(), readers/common.cpp). Linked into the program, Open3D and the hundred libraries
// it pulls in (VTK among them) cost every adit command about 70 ms before main(), though only these
// three imports use it. Private to adit_map and the module, which are built together: the types
// below cross the boundary as they are.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace adit::map::readers_internal {

struct Open3dImage {
  int width = 0, height = 0, channels = 0, bytes_per_channel = 0;
  std::vector<std::uint8_t> data;  // rows top down, channels interleaved, as Open3D keeps them
};

struct Open3dModule {
  int version = 0;
  /// The cloud at `path` in `format` ("pcd", "ply") as x, y, z triples; false with Open3D's last
  /// message (perhaps empty) in `error`. NaN and infinite points are kept.
  bool (*read_cloud)(const char* path, const char* format, std::vector<double>* xyz, std::string* error) = nullptr;
  /// A PNG from memory.
  bool (*read_png)(const unsigned char* data, std::size_t size, Open3dImage* out, std::string* error) = nullptr;
};

constexpr int kOpen3dModuleVersion = 1;
/// The module's one exported symbol: extern "C" const Open3dModule* adit_open3d_module().
constexpr const char* kOpen3dModuleEntry = "adit_open3d_module";

}  // namespace adit::map::readers_internal
