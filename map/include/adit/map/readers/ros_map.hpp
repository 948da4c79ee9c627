// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// ROS map_server maps: a YAML (image, resolution, origin [x, y, yaw], occupied_thresh,
/// free_thresh, negate, mode) and a PGM or PNG image. Each pixel is classified as map_server
/// does in trinary mode (occupancy p = (255 - grey) / 255, or grey / 255 with negate; p >
/// occupied_thresh is occupied, p < free_thresh free, else unknown; a transparent pixel is
/// unknown), then extruded from z = 0 to a height: free columns for ground robots and the
/// papers' 2-D scenarios, occupied columns for walls, unknown stays rock. PGM is read here
/// (netpbm P2/P5), PNG through Open3D; image sizes are checked before decoding.

#include <string>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/readers/geometry.hpp"

namespace adit::map {

struct RosMap {
  std::string image;  ///< as written in the YAML (relative to the YAML's folder)
  double resolution_m = 0.0;
  double origin_x = 0.0, origin_y = 0.0, origin_yaw = 0.0;
  double occupied_thresh = 0.65, free_thresh = 0.196;
  bool negate = false;
  int width = 0, height = 0;
  std::vector<std::int8_t> cells;  ///< row-major from the image's top row: -1 unknown, 0 free, 100 occupied
};

/// True when a YAML text is a map_server map (has an `image:` key) rather than a survey.
bool isRosMapYaml(const std::string& yaml_text);

/// The YAML's fields only (no image). Errors are "name:line:col: field: ...".
StatusOr<RosMap> parseRosMapYaml(const std::string& yaml_text, const std::string& name);
/// Classifies the image bytes (PGM or PNG, by magic) into `map->cells`.
Status decodeRosMapImage(const std::string& image_bytes, const std::string& image_name, RosMap* map,
                         std::uint64_t max_pixels = 400'000'000);
/// YAML file + its image from disk.
StatusOr<RosMap> readRosMap(const std::string& yaml_path);

struct ExtrudeOptions {
  double height_m = 2.0;         ///< free/occupied columns from z = 0 up to this
  double resolution_m = 0.0;     ///< voxel edge; 0: the map's resolution
  Vec3 shift = Vec3::Zero();     ///< subtracted from every coordinate (see --origin)
  UnknownPolicy unknown_policy = UnknownPolicy::kRock;
  std::uint64_t max_voxels = 150'000'000;  // as VoxelizeOptions: ~7 GB while building
};
StatusOr<OccupancyMap> extrudeRosMap(const RosMap& map, const ExtrudeOptions& options);

}  // namespace adit::map
