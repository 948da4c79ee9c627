// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/world.hpp"

#include "map_cache_io.hpp"

#include <chrono>
#include <cstring>
#include <utility>

namespace adit::map {

struct World::Parts {
  Parts(std::string p, LoadedMap l, DistanceField f, WorldTimes t)
      : path(std::move(p)), loaded(std::move(l)), field(std::move(f)), times(t) {}
  std::string path;
  LoadedMap loaded;
  DistanceField field;
  WorldTimes times;
  MapCacheReport cache;
};

namespace {
double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

World::World(std::unique_ptr<Parts> parts) : parts_(std::move(parts)) {}
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

StatusOr<World> World::load(const std::string& path, const WorldOptions& options) {
  if (options.cache.enabled && !options.load.crop) return MapCacheIo::loadThroughCache(path, options);
  const auto t0 = std::chrono::steady_clock::now();
  // The pruning stage is timed through the progress callback: it is voxelize()'s last stage.
  std::chrono::steady_clock::time_point prune0{}, prune1{};
  LoadOptions load = options.load;
  load.progress = [&](const char* stage, double f) {
    if (std::strcmp(stage, kPruneStage) == 0) (f <= 0.0 ? prune0 : prune1) = std::chrono::steady_clock::now();
    if (options.load.progress) options.load.progress(stage, f);
  };
  ADIT_ASSIGN_OR_RETURN(LoadedMap loaded, loadMapAndSurvey(path, load));
  const double load_s = secondsSince(t0);
  StatusOr<World> w = build(std::move(loaded), path, options);
  if (w.ok()) {
    w->parts_->times.load_s = load_s;
    if (prune1 > prune0 && prune0.time_since_epoch().count() != 0)
      w->parts_->times.prune_s = std::chrono::duration<double>(prune1 - prune0).count();
  }
  return w;
}

StatusOr<World> World::build(LoadedMap loaded, std::string path, const WorldOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  StatusOr<DistanceField> field = DistanceField::build(loaded.map, options.load.progress, options.max_field_blocks);
  if (!field.ok())
    return path.empty() ? field.status() : Status(field.status().code(), path + ": " + field.status().message());
  WorldTimes times;
  times.field_s = secondsSince(t0);
  return World(std::make_unique<Parts>(std::move(path), std::move(loaded), std::move(field).value(), times));
}

StatusOr<World> World::fromParts(LoadedMap loaded, DistanceField field, std::string path) {
  if (field.resolution() != loaded.map.resolution())
    return invalidArgument((path.empty() ? std::string() : path + ": ") + "the distance field (voxel " +
                           std::to_string(field.resolution()) + " m) was not built from the map (voxel " +
                           std::to_string(loaded.map.resolution()) + " m)");
  return World(std::make_unique<Parts>(std::move(path), std::move(loaded), std::move(field), WorldTimes{}));
}

World World::copy() const {
  World w(std::make_unique<Parts>(parts_->path, LoadedMap{parts_->loaded.map.deepCopy(), parts_->loaded.survey},
                                  parts_->field, parts_->times));
  w.parts_->cache = parts_->cache;
  return w;
}

const std::string& World::path() const { return parts_->path; }
const OccupancyMap& World::map() const { return parts_->loaded.map; }
OccupancyMap& World::map() { return parts_->loaded.map; }
const DistanceField& World::field() const { return parts_->field; }
DistanceField& World::field() { return parts_->field; }
const SurveyNetwork* World::survey() const { return parts_->loaded.survey ? &*parts_->loaded.survey : nullptr; }
const LoadedMap& World::loaded() const { return parts_->loaded; }
LoadedMap& World::loaded() { return parts_->loaded; }
const WorldTimes& World::times() const { return parts_->times; }
void MapCacheIo::record(World& world, MapCacheReport report, const WorldTimes& times) {
  world.parts_->cache = std::move(report);
  world.parts_->times = times;
}

const MapCacheReport& World::cacheReport() const { return parts_->cache; }

}  // namespace adit::map
