// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The map cache: a world's octree and distance field saved once, so that the next process that
/// loads the same map reads them back instead of voxelizing the survey and running the
/// transform again (2 s → a tenth of that on the district). A cache file is keyed by the map
/// file's content (FNV-1a 64 of its bytes and its size), the unknown-space policy and
/// kMapCacheVersion; any other file, policy or version is foreign and refused. Each section
/// carries a checksum (checksum64) and its structure is checked before anything is built from
/// it, so a torn, truncated, flipped or hostile file is refused and the world is built afresh,
/// never trusted. Files are written through writeFileAtomically: a crash leaves the old cache or
/// none, never half of one.
///
/// Where: beside the map (`district.yaml` → `district.yaml.rock.adit-cache`); when the map's
/// folder cannot be written, in the user's cache folder ($XDG_CACHE_HOME/adit, else
/// ~/.cache/adit) under a name that includes a hash of the map's absolute path. A load looks in
/// both places, beside first. Maps loaded with a crop are never cached.
///
/// Off in the library (WorldOptions::cache.enabled); the adit verbs turn it on unless given
/// --no-cache or ADIT_NO_MAP_CACHE is set (to anything but "" or "0").
///
///   WorldOptions o;
///   o.cache.enabled = true;
///   StatusOr<World> w = World::load("maps/district.yaml", o);   // builds, then writes the cache
///   StatusOr<World> again = World::load("maps/district.yaml", o); // reads it
///   std::puts(again->cacheReport().used.c_str());

#include <cstdint>
#include <string>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"

namespace adit::map {

class World;
struct WorldOptions;

/// Bump whenever the file layout, the voxelizer, the octree readers or the distance field change
/// what they build: a cache of another version is foreign and is rebuilt.
inline constexpr std::uint32_t kMapCacheVersion = 2;

struct MapCacheOptions {
  bool enabled = false;
  /// The fallback folder for maps in read-only folders; empty: $XDG_CACHE_HOME/adit, else
  /// $HOME/.cache/adit.
  std::string user_dir;
};

/// What identifies the world a cache file holds.
struct MapCacheKey {
  std::uint64_t map_hash = 0;  ///< FNV-1a 64 of the map file's bytes
  std::uint64_t map_size = 0;  ///< its length in bytes
  UnknownPolicy policy = UnknownPolicy::kRock;
  std::uint32_t version = kMapCacheVersion;
};
/// The key of `map_path` as it is now. Errors: the map cannot be read (naming it).
StatusOr<MapCacheKey> mapCacheKey(const std::string& map_path, UnknownPolicy policy);

/// The two places a map's cache may be, in the order a load looks.
struct MapCachePaths {
  std::string beside;
  std::string user;  ///< empty when no user cache folder can be named (no XDG_CACHE_HOME, no HOME)
};
MapCachePaths mapCachePaths(const std::string& map_path, UnknownPolicy policy, const MapCacheOptions& options = {});

/// True when ADIT_NO_MAP_CACHE is set to anything but "" or "0".
bool mapCacheDisabledByEnvironment();

/// What a load through the cache did, for the verbs' log and the tests.
struct MapCacheReport {
  std::string used;                  ///< the cache file the world was read from; empty on a miss
  std::vector<std::string> refused;  ///< "FILE: why" for each cache file found and not trusted
  std::string written;               ///< where the rebuilt world's cache went; empty if nowhere
  std::string write_error;           ///< why it could not be written, when it could not
  double read_s = 0.0;               ///< reading and checking the cache file (hit or refusal)
  double write_s = 0.0;
};

/// Writes `world`'s octree and field as the cache file `cache_path` (atomically) under `key`.
Status writeMapCache(const World& world, const MapCacheKey& key, const std::string& cache_path);

/// Reads the cache file `cache_path` of map `map_path`. Refused (the error says why, naming the
/// file): unreadable, not a cache file, another version, another map or policy (`key`), a
/// checksum that does not match, a truncated or over-long file, a structure that does not hold.
/// The survey of a .yaml map is parsed from `map_path` again (it is small; the cache holds what
/// is built from it). `options` gives the memory and field limits the world must respect.
StatusOr<World> readMapCache(const std::string& cache_path, const std::string& map_path, const MapCacheKey& key,
                             const WorldOptions& options);

/// The two halves of World::load through the cache, for loaders that check budgets between
/// reading and building (`adit map query`): a valid cache file of `map_path` (beside, then the
/// user's folder), else NotFound, with what was refused in `report`; and, after a build, the
/// cache written where it can be (what happened goes into `report`, a failure is no error).
StatusOr<World> findCachedWorld(const std::string& map_path, const WorldOptions& options, MapCacheReport* report);
void storeCachedWorld(World& world, const WorldOptions& options, MapCacheReport report);

}  // namespace adit::map
