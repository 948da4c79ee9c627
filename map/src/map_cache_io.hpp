// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit_map: the one friend of World, OccupancyMap and DistanceField that reads and
// writes their insides for the map cache (map_cache.cpp).
#include <string>

#include "adit/map/world.hpp"

namespace adit::map {

struct MapCacheIo {
  // World::load with options.cache.enabled: a valid cache file, else a fresh build whose cache
  // is then written (a failure to write is reported, never an error).
  static StatusOr<World> loadThroughCache(const std::string& path, const WorldOptions& options);
  static Status write(const World& world, const MapCacheKey& key, const std::string& cache_path);
  static StatusOr<World> read(const std::string& cache_path, const std::string& map_path, const MapCacheKey& key,
                              const WorldOptions& options);
  // Records what the cache did (world.cpp: World's parts are private to it).
  static void record(World& world, MapCacheReport report, const WorldTimes& times);
};

}  // namespace adit::map
