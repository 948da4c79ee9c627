// SPDX-License-Identifier: BSD-3-Clause
// The map cache file. See map_cache.hpp for the contract. Layout (native byte order, checked by
// an endianness tag; sections back to back, so that every byte is under a checksum):
//
//   Header (fixed size): magic, version, endianness, the key, six section descriptors
//   (offset, size, checksum64), checksum64 of everything before it.
//   Sections: kMeta (map statistics, field scalars), kOctree (OcTree::writeData's stream),
//   kIndex (the field's dense block index), kCoords (block coordinates), kRegions (each block's
//   tiles), kTiles (the tiles), kFar (the far sites).
#include "adit/map/map_cache.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <octomap/OcTree.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <type_traits>

#include "adit/map/content_hash.hpp"
#include "adit/map/file_io.hpp"
#include "adit/map/survey_network.hpp"
#include "distance_field_impl.hpp"
#include "map_cache_io.hpp"
#include "octree_stream.hpp"

namespace adit::map {

namespace {

namespace fs = std::filesystem;

constexpr char kMagic[8] = {'a', 'd', 'i', 't', 'm', 'c', '\r', '\n'};
constexpr std::uint32_t kEndianTag = 0x01020304u;
enum Section : int { kMeta, kOctree, kIndex, kCoords, kRegions, kTiles, kFar, kSectionCount };
const char* const kSectionNames[kSectionCount] = {"statistics",   "octree", "block index", "block coordinates",
                                                  "block tiles", "tiles",  "far sites"};

struct SectionDesc {
  std::uint64_t offset, size, checksum;
};
struct Header {
  char magic[8];
  std::uint32_t version, endian;
  std::uint64_t map_hash, map_size;
  std::uint32_t policy, sections;
  SectionDesc section[kSectionCount];
  std::uint64_t checksum;  // of the bytes above
};
static_assert(std::is_trivially_copyable_v<Header> && sizeof(Header) == 8 + 8 + 16 + 8 + 24 * kSectionCount + 8);

// Every field 8 bytes wide: no padding, so the bytes written are exactly the values.
struct Meta {
  double map_resolution;
  double bounds[6];
  std::uint64_t free_voxels, occupied_voxels, unknown_voxels, octree_nodes;
  double field_resolution;
  std::int64_t bmin[3], bdim[3];
  std::uint64_t blocks, index_entries, tiles, far_sites, tile_edge;
  std::uint64_t f_free_voxels, f_blocks, f_index_entries, f_memory_bytes;
  double f_build_seconds, f_transform_seconds, f_max_distance_m;
};
static_assert(std::is_trivially_copyable_v<Meta> && sizeof(Meta) % 8 == 0);

std::uint64_t headerChecksum(const Header& h) { return checksum64(&h, offsetof(Header, checksum)); }

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string hex16(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// The octree stream's structure without building it: each node is a finite float log-odds and a
// child bitmask, depth at most 16, exactly `nodes` nodes filling exactly the bytes. The tree, the
// voxel states and the leaves read from these bytes trust that; nothing reaches them that has
// not passed here.
Status checkOctreeStream(const std::string& data, std::uint64_t nodes) {
  bool finite = true;
  const StreamWalk w = walkOctreeStream<false>(data, [&finite](const StreamNode& n) { return finite = std::isfinite(n.log_odds); });
  switch (w.end) {
    case StreamWalk::kWhole: break;
    case StreamWalk::kTooDeep: return dataLoss("octree: a node below depth 16");
    case StreamWalk::kCut:
    case StreamWalk::kStopped:
      if (w.nodes == 0 || (w.nodes == 1 && !finite)) return dataLoss("octree: the root node is cut or not finite");
      return dataLoss("octree: node " + std::to_string(w.nodes) + " is cut or not finite");
  }
  if (w.bytes != data.size()) return dataLoss("octree: " + std::to_string(data.size() - w.bytes) + " bytes after the tree");
  if (w.nodes != nodes)
    return dataLoss("octree: " + std::to_string(w.nodes) + " nodes, the statistics say " + std::to_string(nodes));
  return {};
}

// Reads exactly `size` bytes at `offset`; false on a short read.
bool readAt(int fd, std::uint64_t offset, void* out, std::uint64_t size) {
  auto* p = static_cast<char*>(out);
  while (size > 0) {
    const ssize_t n = ::pread(fd, p, std::size_t(std::min<std::uint64_t>(size, std::uint64_t{1} << 30)), off_t(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    offset += std::uint64_t(n);
    size -= std::uint64_t(n);
  }
  return true;
}

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

std::string userCacheDir(const MapCacheOptions& o) {
  if (!o.user_dir.empty()) return o.user_dir;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x && x[0] == '/') return std::string(x) + "/adit";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/adit";
  return {};
}

}  // namespace

bool mapCacheDisabledByEnvironment() {
  const char* v = std::getenv("ADIT_NO_MAP_CACHE");
  return v && *v && std::strcmp(v, "0") != 0;
}

StatusOr<MapCacheKey> mapCacheKey(const std::string& map_path, UnknownPolicy policy) {
  ADIT_ASSIGN_OR_RETURN(const std::string bytes, readFile(map_path));
  MapCacheKey k;
  k.map_hash = fnv1a64(bytes);
  k.map_size = bytes.size();
  k.policy = policy;
  return k;
}

MapCachePaths mapCachePaths(const std::string& map_path, UnknownPolicy policy, const MapCacheOptions& options) {
  const std::string suffix = std::string(".") + unknownPolicyName(policy) + ".adit-cache";
  MapCachePaths p;
  p.beside = map_path + suffix;
  const std::string dir = userCacheDir(options);
  if (!dir.empty()) {
    std::error_code ec;
    fs::path abs = fs::absolute(map_path, ec);
    if (ec) abs = map_path;
    const fs::path canonical = fs::weakly_canonical(abs, ec);
    const std::string where = (ec ? abs : canonical).string();
    // The folder's hash keeps two maps of one name apart; the name keeps the folder readable.
    p.user = dir + "/" + hex16(fnv1a64(where)) + "-" + fs::path(map_path).filename().string() + suffix;
  }
  return p;
}

Status writeMapCache(const World& world, const MapCacheKey& key, const std::string& cache_path) {
  return MapCacheIo::write(world, key, cache_path);
}

StatusOr<World> readMapCache(const std::string& cache_path, const std::string& map_path, const MapCacheKey& key,
                             const WorldOptions& options) {
  return MapCacheIo::read(cache_path, map_path, key, options);
}

Status MapCacheIo::write(const World& world, const MapCacheKey& key, const std::string& cache_path) {
  const OccupancyMap& map = world.map();
  const DistanceField::Impl& f = *world.field().impl_;
  std::ostringstream tree_out;
  map.octree().writeData(tree_out);
  const std::string tree = std::move(tree_out).str();

  Meta m{};
  const MapStats& s = map.stats();
  m.map_resolution = s.resolution_m;
  for (int a = 0; a < 3; ++a) {
    m.bounds[a] = s.bounds.min[a];
    m.bounds[3 + a] = s.bounds.max[a];
    m.bmin[a] = f.bmin[a];
    m.bdim[a] = f.bdim[a];
  }
  m.free_voxels = s.free_voxels;
  m.occupied_voxels = s.occupied_voxels;
  m.unknown_voxels = s.unknown_voxels;
  m.octree_nodes = s.octree_nodes;
  m.field_resolution = f.res;
  m.blocks = f.regions.size();
  m.index_entries = f.index.size();
  m.tiles = f.tiles.size();
  m.far_sites = f.far.size();
  m.tile_edge = kTileSize;
  m.f_free_voxels = f.stats.free_voxels;
  m.f_blocks = f.stats.blocks;
  m.f_index_entries = f.stats.index_entries;
  m.f_memory_bytes = f.stats.memory_bytes;
  m.f_build_seconds = f.stats.build_seconds;
  m.f_transform_seconds = f.stats.transform_seconds;
  m.f_max_distance_m = f.stats.max_distance_m;

  const void* data[kSectionCount] = {&m,                  tree.data(),    f.index.data(), f.block_coords.data(),
                                     f.regions.data(),    f.tiles.data(), f.far.data()};
  const std::uint64_t sizes[kSectionCount] = {sizeof m,
                                              tree.size(),
                                              f.index.size() * sizeof(std::int32_t),
                                              f.block_coords.size() * sizeof(std::array<int, 3>),
                                              f.regions.size() * sizeof(Region),
                                              f.tiles.size() * sizeof(Tile),
                                              f.far.size() * sizeof(std::uint64_t)};
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = key.version;
  h.endian = kEndianTag;
  h.map_hash = key.map_hash;
  h.map_size = key.map_size;
  h.policy = std::uint32_t(key.policy);
  h.sections = kSectionCount;
  std::uint64_t at = sizeof h;
  for (int i = 0; i < kSectionCount; ++i) {
    h.section[i] = {at, sizes[i], checksum64(data[i], std::size_t(sizes[i]))};
    at += sizes[i];
  }
  h.checksum = headerChecksum(h);
  return writeFileAtomically(cache_path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(&h), sizeof h);
    for (int i = 0; i < kSectionCount; ++i) out.write(static_cast<const char*>(data[i]), std::streamsize(sizes[i]));
    return bool(out);
  });
}

StatusOr<World> MapCacheIo::read(const std::string& cache_path, const std::string& map_path, const MapCacheKey& key,
                                 const WorldOptions& options) {
  auto refuse = [&](const std::string& why) { return dataLoss(cache_path + ": " + why); };
  Fd fd;
  fd.fd = ::open(cache_path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd.fd < 0) return notFound(cache_path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd.fd, &st) != 0 || !S_ISREG(st.st_mode)) return refuse("not a regular file");
  const auto file_size = std::uint64_t(st.st_size);
  Header h{};
  if (file_size < sizeof h || !readAt(fd.fd, 0, &h, sizeof h)) return refuse("shorter than a cache header");
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) return refuse("not an adit map cache");
  if (h.endian != kEndianTag) return refuse("written on a machine of another byte order");
  if (h.version != key.version)
    return failedPrecondition(cache_path + ": cache format version " + std::to_string(h.version) +
                              ", this adit reads version " + std::to_string(key.version));
  if (headerChecksum(h) != h.checksum) return refuse("header checksum does not match");
  if (h.sections != kSectionCount) return refuse("header names " + std::to_string(h.sections) + " sections");
  if (h.map_hash != key.map_hash || h.map_size != key.map_size)
    return failedPrecondition(cache_path + ": made from another map (content fnv1a64:" + hex16(h.map_hash) + ", " +
                              std::to_string(h.map_size) + " bytes; " + map_path + " is fnv1a64:" +
                              hex16(key.map_hash) + ", " + std::to_string(key.map_size) + " bytes)");
  if (h.policy != std::uint32_t(key.policy))
    return failedPrecondition(cache_path + ": built with another unknown-space policy");
  std::uint64_t end = sizeof h;
  for (int i = 0; i < kSectionCount; ++i) {
    const SectionDesc& d = h.section[i];
    if (d.offset != end || d.offset > file_size || d.size > file_size - d.offset)
      return refuse(std::string(kSectionNames[i]) + " section lies outside the file (truncated?)");
    end = d.offset + d.size;
  }
  if (end != file_size) return refuse(std::to_string(file_size - end) + " bytes after the last section");
  auto section = [&](int i, void* out, std::uint64_t expected) -> Status {
    const SectionDesc& d = h.section[i];
    if (d.size != expected)
      return refuse(std::string(kSectionNames[i]) + " section is " + std::to_string(d.size) + " bytes, expected " +
                    std::to_string(expected));
    if (!readAt(fd.fd, d.offset, out, d.size)) return refuse(std::string("cannot read the ") + kSectionNames[i]);
    if (checksum64(out, std::size_t(d.size)) != d.checksum)
      return refuse(std::string(kSectionNames[i]) + " checksum does not match");
    return {};
  };

  Meta m{};
  ADIT_RETURN_IF_ERROR(section(kMeta, &m, sizeof m));
  // The sizes the statistics imply, checked before anything of that size is allocated.
  double index_cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (m.bdim[a] < 0 || m.bdim[a] > 4096 || m.bmin[a] < 0 || m.bmin[a] + m.bdim[a] > 4096)
      return refuse("tile grid out of the key range");
    index_cells *= double(m.bdim[a]);
  }
  if (double(m.index_entries) != index_cells) return refuse("tile index does not match the tile grid");
  if (m.blocks > options.max_field_blocks)
    return failedPrecondition(cache_path + ": the field has " + std::to_string(m.blocks) + " tiles, above the limit " +
                              std::to_string(options.max_field_blocks));
  if (m.tile_edge != std::uint64_t(kTileSize) || m.tiles < 1 || m.tiles > m.blocks * kTilesPerBlock + 1 ||
      m.far_sites > m.tiles * kTileVoxels)
    return refuse("tile counts do not match the blocks");
  const double bytes = double(h.section[kOctree].size) + double(m.index_entries) * 4.0 +
                       double(m.blocks) * (sizeof(Region) + 12.0) + double(m.tiles) * sizeof(Tile) +
                       double(m.far_sites) * 8.0;
  if (bytes > double(options.load.max_memory_bytes))
    return failedPrecondition(cache_path + ": the cached world needs " + std::to_string(std::uint64_t(bytes)) +
                              " bytes, above the memory limit");
  if (!(m.map_resolution > 0.0) || m.map_resolution != m.field_resolution || !checkResolution(m.map_resolution).ok())
    return refuse("resolution of the map and the field disagree or are invalid");

  std::string tree;
  tree.reserve(std::size_t(h.section[kOctree].size));
  adviseHugePages(tree.data(), tree.capacity());
  tree.resize(std::size_t(h.section[kOctree].size));
  ADIT_RETURN_IF_ERROR(section(kOctree, tree.data(), tree.size()));
  if (Status s = checkOctreeStream(tree, m.octree_nodes); !s.ok()) return refuse(s.message());

  auto impl = std::make_unique<DistanceField::Impl>();
  impl->res = m.field_resolution;
  impl->inv = 1.0 / impl->res;
  for (int a = 0; a < 3; ++a) {
    impl->bmin[a] = int(m.bmin[a]);
    impl->bdim[a] = int(m.bdim[a]);
  }
  impl->index.resize(std::size_t(m.index_entries));
  ADIT_RETURN_IF_ERROR(section(kIndex, impl->index.data(), m.index_entries * sizeof(std::int32_t)));
  impl->block_coords.resize(std::size_t(m.blocks));
  ADIT_RETURN_IF_ERROR(section(kCoords, impl->block_coords.data(), m.blocks * sizeof(std::array<int, 3>)));
  impl->regions.resize(std::size_t(m.blocks));
  ADIT_RETURN_IF_ERROR(section(kRegions, impl->regions.data(), m.blocks * sizeof(Region)));
  impl->tiles.reserve(std::size_t(m.tiles));
  adviseHugePages(impl->tiles);
  impl->tiles.resize(std::size_t(m.tiles));
  ADIT_RETURN_IF_ERROR(section(kTiles, impl->tiles.data(), m.tiles * sizeof(Tile)));
  impl->far.resize(std::size_t(m.far_sites));
  ADIT_RETURN_IF_ERROR(section(kFar, impl->far.data(), m.far_sites * sizeof(std::uint64_t)));
  // Every block the index names exists and sits where its coordinates say, and each block and
  // each tile is named once; every far cell names a far site. A query trusts all of these, so a
  // hostile file must not get this far.
  std::vector<char> named(impl->regions.size(), 0);
  for (std::size_t i = 0; i < impl->index.size(); ++i) {
    const std::int32_t b = impl->index[i];
    if (b == -1) continue;
    if (b < 0 || std::uint64_t(b) >= m.blocks || named[std::size_t(b)]) return refuse("tile index names a bad tile");
    named[std::size_t(b)] = 1;
    const std::array<int, 3>& c = impl->block_coords[std::size_t(b)];
    const std::size_t x = std::size_t(c[0] - impl->bmin[0]), y = std::size_t(c[1] - impl->bmin[1]),
                      z = std::size_t(c[2] - impl->bmin[2]);
    if ((z * std::size_t(impl->bdim[1]) + y) * std::size_t(impl->bdim[0]) + x != i)
      return refuse("tile coordinates disagree with the index");
  }
  if (std::find(named.begin(), named.end(), 0) != named.end()) return refuse("a tile the index does not name");
  std::vector<char> tile_named(impl->tiles.size(), 0);
  tile_named[kRockTile] = 1;
  for (const Region& r : impl->regions)
    for (const std::int32_t t : r) {
      if (t == kRockTile) continue;
      if (t < 0 || std::uint64_t(t) >= m.tiles || tile_named[std::size_t(t)]) return refuse("a block names a bad tile");
      tile_named[std::size_t(t)] = 1;
    }
  if (std::find(tile_named.begin(), tile_named.end(), 0) != tile_named.end()) return refuse("a tile no block names");
  for (const Cell c : impl->tiles[kRockTile])
    if (c != 0) return refuse("the shared rock tile is not rock");
  for (const Tile& t : impl->tiles)
    for (const Cell c : t)
      if (isFarCell(c) && (c & kFarIndexMask) >= m.far_sites) return refuse("a cell names a far site that is not there");
  impl->stats.free_voxels = m.f_free_voxels;
  impl->stats.blocks = m.f_blocks;
  impl->stats.index_entries = m.f_index_entries;
  impl->stats.memory_bytes = m.f_memory_bytes;
  impl->stats.build_seconds = m.f_build_seconds;
  impl->stats.transform_seconds = m.f_transform_seconds;
  impl->stats.max_distance_m = m.f_max_distance_m;

  MapStats ms;
  ms.resolution_m = m.map_resolution;
  ms.bounds = Aabb(Vec3(m.bounds[0], m.bounds[1], m.bounds[2]), Vec3(m.bounds[3], m.bounds[4], m.bounds[5]));
  ms.free_voxels = m.free_voxels;
  ms.occupied_voxels = m.occupied_voxels;
  ms.unknown_voxels = m.unknown_voxels;
  ms.octree_nodes = m.octree_nodes;
  LoadedMap loaded{OccupancyMap::fromOctreeData(std::move(tree), key.policy, ms), std::nullopt};
  StatusOr<MapFormat> format = formatFromPath(map_path);
  if (format.ok() && *format == MapFormat::kSurveyYaml) {
    ADIT_ASSIGN_OR_RETURN(SurveyNetwork net, loadSurvey(map_path, options.load.max_memory_bytes));
    if (net.resolution_m != m.map_resolution) return refuse("the survey's resolution is not the cached map's");
    loaded.survey = std::move(net);
  }
  return World::fromParts(std::move(loaded), DistanceField(std::move(impl)), map_path);
}

StatusOr<World> findCachedWorld(const std::string& map_path, const WorldOptions& options, MapCacheReport* report) {
  MapCacheReport local;
  MapCacheReport& r = report ? *report : local;
  StatusOr<MapCacheKey> key = mapCacheKey(map_path, options.load.unknown_policy);
  if (!key.ok()) return key.status();
  const MapCachePaths where = mapCachePaths(map_path, options.load.unknown_policy, options.cache);
  const auto t0 = std::chrono::steady_clock::now();
  for (const std::string* candidate : {&where.beside, &where.user}) {
    std::error_code ec;
    if (candidate->empty() || !fs::exists(*candidate, ec)) continue;
    if (options.load.progress) options.load.progress("reading map cache", 0.0);
    StatusOr<World> w = MapCacheIo::read(*candidate, map_path, *key, options);
    r.read_s = secondsSince(t0);
    if (w.ok()) {
      if (options.load.progress) options.load.progress("reading map cache", 1.0);
      r.used = *candidate;
      WorldTimes times;
      times.cache_read_s = r.read_s;
      MapCacheIo::record(*w, r, times);
      return w;
    }
    r.refused.push_back(w.status().message());
  }
  return notFound(map_path + ": no valid map cache");
}

void storeCachedWorld(World& world, const WorldOptions& options, MapCacheReport report) {
  const auto t0 = std::chrono::steady_clock::now();
  StatusOr<MapCacheKey> key = mapCacheKey(world.path(), options.load.unknown_policy);
  std::string errors = key.ok() ? std::string() : key.status().message();
  const MapCachePaths where = mapCachePaths(world.path(), options.load.unknown_policy, options.cache);
  // Beside the map when its folder can be written; the user's folder otherwise.
  for (const std::string* target : {&where.beside, &where.user}) {
    if (!key.ok() || target->empty()) continue;
    std::error_code ec;
    if (target == &where.user) fs::create_directories(fs::path(*target).parent_path(), ec);
    if (Status s = MapCacheIo::write(world, *key, *target); s.ok()) {
      report.written = *target;
      break;
    } else {
      errors += (errors.empty() ? "" : "; ") + s.message();
    }
  }
  if (report.written.empty()) report.write_error = errors.empty() ? "no cache folder (no HOME)" : errors;
  report.write_s = secondsSince(t0);
  WorldTimes times = world.times();
  times.cache_read_s = report.read_s;
  times.cache_write_s = report.write_s;
  MapCacheIo::record(world, std::move(report), times);
}

StatusOr<World> MapCacheIo::loadThroughCache(const std::string& path, const WorldOptions& options) {
  WorldOptions fresh = options;
  fresh.cache.enabled = false;
  MapCacheReport report;
  StatusOr<World> cached = findCachedWorld(path, options, &report);
  if (cached.ok()) return cached;
  ADIT_ASSIGN_OR_RETURN(World w, World::load(path, fresh));
  storeCachedWorld(w, options, std::move(report));
  return w;
}

}  // namespace adit::map
