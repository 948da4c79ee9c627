// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// `adit map convert` for imported data (point clouds, meshes) and frame shifts of surveys: the
// options and the run. map_verbs.cpp registers the verb and calls in here.
#include <optional>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace adit::tools {

struct ConvertArgs {
  std::string in, out, unknown = "rock";
  bool quiet = false, json = false;
  bool cache = false;  // --cache: write OUT's map cache too
  std::optional<double> resolution;
  std::string seed, trajectory, origin, up = "z";
  std::string sections, section;  // DXF centrelines
  double height = 2.0;
  double max_wall_distance = 5.0, close = 0.0, max_ray = 60.0, hull_cell = 0.0;
  std::optional<double> thin;  // --thin: unset = one voxel
  /// --max-memory as given (empty: the import's default, 4G); --max-memory-mb is its old spelling.
  std::string max_memory;
  std::optional<double> max_memory_mb;
  double max_points = 5e8;
};

/// Registers the import options on `cmd` (the convert subcommand).
void addConvertOptions(CLI::App* cmd, ConvertArgs* a);
/// True when the input or the options need the import path (not a plain survey/.bt copy).
bool needsImport(const ConvertArgs& a);
int runImportConvert(const ConvertArgs& a);

}  // namespace adit::tools
