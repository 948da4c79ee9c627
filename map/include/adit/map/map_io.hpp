// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Reading and writing maps. Readers validate a whole file before anything is built from it
/// (OctoMap's own readers trust their input: a truncated .bt makes them read garbage), and
/// writers go through a temporary file renamed into place, so a failed or interrupted write
/// never leaves a half file behind (see writeFileAtomically for devices, FIFOs and symlinks).
///
///   StatusOr<OccupancyMap> map = loadMap("maps/district.yaml");   // survey, .bt or .ot
///   Status s = writeOctomap(*map, "district.bt");

#include <functional>
#include <optional>
#include <ostream>
#include <string>

#include "adit/map/file_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {

enum class MapFormat { kSurveyYaml, kOctomapBinary, kOctomapFull };

/// From the file extension: .yaml/.yml, .bt, .ot (case-insensitive).
StatusOr<MapFormat> formatFromPath(const std::string& path);

struct LoadOptions {
  UnknownPolicy unknown_policy = UnknownPolicy::kRock;
  ProgressFn progress;  ///< optional
  /// Every step (file, parse, voxels, octree, crop) is estimated first and refused above this.
  std::uint64_t max_memory_bytes = kDefaultMaxMemoryBytes;
  /// Keep only the voxels whose centre lies in this box; a survey is cut to the roadway
  /// segments that reach into it before it is voxelized, so a part of a huge network fits.
  std::optional<Aabb> crop;
};

/// Loads any supported map: a survey roadway network (voxelized), an OctoMap .bt or .ot.
StatusOr<OccupancyMap> loadMap(const std::string& path, const LoadOptions& options = {});

/// A loaded map and, when it came from a survey, the network itself (its centrelines are exact).
struct LoadedMap {
  OccupancyMap map;
  std::optional<SurveyNetwork> survey;
};
/// loadMap() that keeps the survey network.
StatusOr<LoadedMap> loadMapAndSurvey(const std::string& path, const LoadOptions& options = {});

/// OctoMap binary (.bt) or full (.ot, OcTree only) from a file or from bytes; `name` is used in
/// messages. Every structural fact is checked: magic line, header fields, node encoding, depth
/// <= 16, node count equal to the header's, no trailing bytes, finite log-odds.
StatusOr<OccupancyMap> loadOctomap(const std::string& path, UnknownPolicy policy = UnknownPolicy::kRock,
                                   std::uint64_t max_memory_bytes = kDefaultMaxMemoryBytes);
/// The header's node count is checked (after the node stream is validated against it) against
/// `max_memory_bytes` before the tree is built.
StatusOr<OccupancyMap> parseOctomap(const std::string& bytes, const std::string& name,
                                    UnknownPolicy policy = UnknownPolicy::kRock,
                                    std::uint64_t max_memory_bytes = kDefaultMaxMemoryBytes);

/// Writes .bt or .ot (by extension) atomically.
Status writeOctomap(const OccupancyMap& map, const std::string& path);

}  // namespace adit::map
