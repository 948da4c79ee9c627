// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/map_io.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {

namespace {

const char* kCropHint = "use --crop xmin,ymin,zmin,xmax,ymax,zmax to load a part, a coarser resolution, or raise --max-memory";

StatusOr<LoadedMap> applyCrop(LoadedMap loaded, const LoadOptions& options, const std::string& path) {
  if (!options.crop) return loaded;
  const MemoryBudget budget{options.max_memory_bytes};
  ADIT_RETURN_IF_ERROR(budget.check(estimateCropBytes(loaded.map, *options.crop), path + ": cropping",
                                    "use a smaller --crop box or raise --max-memory"));
  StatusOr<OccupancyMap> part = cropMap(loaded.map, *options.crop);
  if (!part.ok()) return Status(part.status().code(), path + ": " + part.status().message());
  loaded.map = std::move(part).value();
  return loaded;
}

}  // namespace

StatusOr<LoadedMap> loadMapAndSurvey(const std::string& path, const LoadOptions& options) {
  StatusOr<MapFormat> format = formatFromPath(path);
  if (!format.ok()) return format.status();
  if (*format != MapFormat::kSurveyYaml) {
    StatusOr<OccupancyMap> map = loadOctomap(path, options.unknown_policy, options.max_memory_bytes);
    if (!map.ok()) return map.status();
    return applyCrop(LoadedMap{std::move(map).value(), std::nullopt}, options, path);
  }
  StatusOr<SurveyNetwork> net = loadSurvey(path, options.max_memory_bytes);
  if (!net.ok()) return net.status();
  if (options.crop) {
    // Cut the network first, so that only the roadways near the box are voxelized.
    StatusOr<SurveyNetwork> part = cropNetwork(*net, *options.crop);
    if (!part.ok()) return Status(part.status().code(), path + ": " + part.status().message());
    net = std::move(part);
  }
  ADIT_RETURN_IF_ERROR(MemoryBudget{options.max_memory_bytes}.check(
      estimateVoxelizeBytes(*net), path + ": voxelizing the survey network (about " +
                                       std::to_string(std::uint64_t(net->estimatedVoxels())) + " voxels)",
      kCropHint));
  VoxelizeOptions vo;
  vo.unknown_policy = options.unknown_policy;
  vo.progress = options.progress;
  StatusOr<OccupancyMap> map = voxelize(*net, vo);
  if (!map.ok()) return Status(map.status().code(), path + ": " + map.status().message());
  return applyCrop(LoadedMap{std::move(map).value(), std::move(net).value()}, options, path);
}

StatusOr<OccupancyMap> loadMap(const std::string& path, const LoadOptions& options) {
  StatusOr<LoadedMap> loaded = loadMapAndSurvey(path, options);
  if (!loaded.ok()) return loaded.status();
  return std::move(loaded).value().map;
}

}  // namespace adit::map
