// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/map_io.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {

StatusOr<LoadedMap> loadMapAndSurvey(const std::string& path, const LoadOptions& options) {
  StatusOr<MapFormat> format = formatFromPath(path);
  if (!format.ok()) return format.status();
  if (*format != MapFormat::kSurveyYaml) {
    StatusOr<OccupancyMap> map = loadOctomap(path, options.unknown_policy);
    if (!map.ok()) return map.status();
    return LoadedMap{std::move(map).value(), std::nullopt};
  }
  StatusOr<SurveyNetwork> net = loadSurvey(path);
  if (!net.ok()) return net.status();
  VoxelizeOptions vo;
  vo.unknown_policy = options.unknown_policy;
  vo.progress = options.progress;
  StatusOr<OccupancyMap> map = voxelize(*net, vo);
  if (!map.ok()) return Status(map.status().code(), path + ": " + map.status().message());
  return LoadedMap{std::move(map).value(), std::move(net).value()};
}

StatusOr<OccupancyMap> loadMap(const std::string& path, const LoadOptions& options) {
  StatusOr<LoadedMap> loaded = loadMapAndSurvey(path, options);
  if (!loaded.ok()) return loaded.status();
  return std::move(loaded).value().map;
}

}  // namespace adit::map
