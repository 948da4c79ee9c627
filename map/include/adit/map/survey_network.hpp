// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The survey roadway network, adit's main input: survey stations (points on the roadway floor),
/// named cross-sections, and roadways that run a section along a centreline through stations.
/// loadSurvey() reads a survey YAML file (`name`, `resolution`, `rock_shell`, then `stations`,
/// `sections` and `roadways`, the fields of SurveyNetwork below) and reports any mistake with
/// file, line and field; voxelize() turns the network into an OccupancyMap: free inside every
/// section swept along its centreline (floor flat across the section, junctions open), a shell
/// of occupied rock around it, and unknown (= rock by default) beyond.
///
///   StatusOr<SurveyNetwork> net = loadSurvey("maps/district.yaml");
///   StatusOr<OccupancyMap> map = voxelize(*net);
///   std::cout << net->totalLength() << " m of roadway\n";

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "adit/map/cross_section.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct SurveyRoadway {
  std::string name;
  std::vector<std::string> stations;  ///< at least two, in order along the centreline
  std::string section;                ///< key into SurveyNetwork::sections
};

struct SurveyNetwork {
  std::string name;                   ///< optional `name:` field
  double resolution_m = 0.2;          ///< voxel edge
  double rock_shell_m = 0.6;          ///< occupied rock written around the roadways (at least this thick)
  std::map<std::string, Vec3> stations;
  std::map<std::string, CrossSection> sections;
  std::vector<SurveyRoadway> roadways;

  /// References resolve, values are finite and positive, segments are not vertical, and the
  /// whole network fits OctoMap's key range at the resolution.
  Status validate() const;
  /// Sum of the roadway centreline lengths [m] (3-D, along the floor).
  double totalLength() const;
  Polyline centreline(const SurveyRoadway& roadway) const;
  /// Everything voxelize() will touch: centrelines grown by the sections and the rock shell.
  Aabb bounds() const;
  /// Upper estimate of the voxels voxelize() creates (free + shell), to refuse absurd inputs
  /// before allocating.
  double estimatedVoxels() const;
};

/// Parses the YAML text; `name` (usually the path) prefixes every error as "name:line:col: ...".
StatusOr<SurveyNetwork> parseSurvey(const std::string& yaml_text, const std::string& name);
/// Refuses (before parsing) a file whose parse would need more than `max_memory_bytes`.
StatusOr<SurveyNetwork> loadSurvey(const std::string& path, std::uint64_t max_memory_bytes = kDefaultMaxMemoryBytes);

/// The part of the network that can put a voxel in `box`: every run of consecutive segments
/// whose swept section (with its rock shell) reaches into the box becomes a roadway (named
/// "<name>" or "<name>/<k>" when a roadway is cut into several runs). Refuses a box that no
/// roadway reaches. voxelize() of the result, cropped to the box, equals the whole network's
/// voxels in the box except at the cut ends (no revolve where a run ends inside the grown box).
StatusOr<SurveyNetwork> cropNetwork(const SurveyNetwork& network, const Aabb& box);

/// The progress stage of voxelize() that prunes the octree and counts its voxels (the last).
inline constexpr const char* kPruneStage = "pruning octree";

struct VoxelizeOptions {
  UnknownPolicy unknown_policy = UnknownPolicy::kRock;
  /// Refuse larger maps: OctoMap needs about 45 bytes a voxel while building (before pruning),
  /// so the default keeps a build under about 7 GB.
  double max_voxels = 1.5e8;
  ProgressFn progress;      ///< optional
};

StatusOr<OccupancyMap> voxelize(const SurveyNetwork& network, const VoxelizeOptions& options = {});

}  // namespace adit::map
