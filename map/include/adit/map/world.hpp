// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// A world: a map ready to plan on, check against and navigate in. It bundles the occupancy map
/// (unknown is rock unless asked otherwise), the survey network it was voxelized from (when it
/// came from a survey: its centrelines are exact) and the map's exact distance field, built by
/// one loader for every user: `adit plan`, the navigator's believed world, the simulator's true
/// world, batches and campaigns, and the operations console. The map and the field live on the
/// heap, so a World can be moved while planners, checkers and the field's users point into it;
/// copy() gives an independent deep copy (a navigator's belief that may change while the true
/// world the referee checks stays as it was).
///
///   StatusOr<World> w = World::load("maps/district.yaml");
///   double d = w->field().distance({10, 0, 1.5});
///   World belief = w->copy();                      // mutate belief, w is untouched

#include <cstdint>
#include <memory>
#include <string>

#include "adit/map/distance_field.hpp"
#include "adit/map/map_cache.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"

namespace adit::map {

struct WorldOptions {
  LoadOptions load;  ///< the map loader's (unknown policy, progress, memory budget, crop)
  /// The field refuses maps whose free space would need more tiles (DistanceField::build).
  std::uint64_t max_field_blocks = std::uint64_t{1} << 20;
  /// Read the world from the map cache when a valid one is there, else build it and write one
  /// (map_cache.hpp). Off by default; ignored with a crop.
  MapCacheOptions cache;
};

/// Wall time of each phase of World::load, so a verb can say where its start-up went.
struct WorldTimes {
  double load_s = 0.0;   ///< reading the file and, for a survey, voxelizing it
  double prune_s = 0.0;  ///< of load_s: pruning the voxelized octree and its statistics (kPruneStage)
  double field_s = 0.0;  ///< the distance transform
  double cache_read_s = 0.0;   ///< looking for, reading and checking cache files
  double cache_write_s = 0.0;  ///< writing the cache after a build
};

class World {
 public:
  /// Loads `path` (survey .yaml, .bt or .ot; see loadMapAndSurvey) and builds its field, feeding
  /// options.load.progress through both phases. Errors name the file.
  static StatusOr<World> load(const std::string& path, const WorldOptions& options = {});
  /// A world of a map already loaded: builds the field. `path` names it (may be empty).
  static StatusOr<World> build(LoadedMap loaded, std::string path = {}, const WorldOptions& options = {});
  /// A world of a map and a field already built from it (DistanceField::build(loaded.map)); a
  /// field of another resolution or size is refused.
  static StatusOr<World> fromParts(LoadedMap loaded, DistanceField field, std::string path = {});

  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  ~World();

  /// An independent deep copy: map, survey and field; changing one never touches the other.
  World copy() const;

  /// The file it was loaded from ("" when built from parts without one).
  const std::string& path() const;
  const OccupancyMap& map() const;
  OccupancyMap& map();
  const DistanceField& field() const;
  DistanceField& field();
  /// The survey network it was voxelized from; null for a .bt/.ot, scan or mesh.
  const SurveyNetwork* survey() const;
  /// Map and survey together, for the interfaces that take a LoadedMap.
  const LoadedMap& loaded() const;
  LoadedMap& loaded();
  const WorldTimes& times() const;
  /// What the map cache did for this world (all empty when the cache was not asked for).
  const MapCacheReport& cacheReport() const;

 private:
  friend struct MapCacheIo;
  struct Parts;
  explicit World(std::unique_ptr<Parts> parts);
  std::unique_ptr<Parts> parts_;
};

}  // namespace adit::map
