// SPDX-License-Identifier: BSD-3-Clause
// Size estimates for every structure built from an input, and the crop that makes a big map fit.
#include "adit/map/size_estimate.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <unistd.h>
#include <unordered_set>

#include "adit/map/survey_network.hpp"
#include "voxel_blocks.hpp"

namespace adit::map {

namespace {

// Measured on OctoMap 1.9.7 / yaml-cpp 0.7 (x86-64): see the figures in each function.
constexpr double kOctreeBytesPerNode = 40.0;      // 16 B node + 64 B child array per inner node
constexpr double kOctreeBuildBytesPerVoxel = 45.0;  // setNodeValue on unpruned leaves
constexpr double kYamlBytesPerToken = 700.0;      // 10^5 stations (5*10^5 tokens): 328 MB peak
// The field's layout (distance_field_impl.hpp): 16^3 blocks, each an index entry, coordinates
// and a record of its 8^3 tiles; the tiles hold 4-byte cells.
constexpr int kBlockVoxels = internal::kBlockVoxels;
constexpr int kTileBits = internal::kFieldTileBits;
constexpr double kTileBytes = double(1 << (3 * kTileBits)) * 4.0;
constexpr double kBlockBytes = 12.0 + 4.0 * double(1 << (3 * (internal::kBlockBits - kTileBits)));

std::uint64_t tileKey(int bx, int by, int bz) {
  return std::uint64_t(std::uint32_t(bx)) | (std::uint64_t(std::uint32_t(by)) << 20) |
         (std::uint64_t(std::uint32_t(bz)) << 40);
}

}  // namespace

std::uint64_t machineMemoryBudgetBytes() {
  constexpr std::uint64_t kCap = std::uint64_t{8} << 30;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return kDefaultMaxMemoryBytes;  // unknown: the library's default
  const double three_quarters = 0.75 * double(pages) * double(page);
  return std::clamp(std::uint64_t(three_quarters), kDefaultMaxMemoryBytes, kCap);
}

StatusOr<std::uint64_t> parseByteSize(const std::string& text) {
  const char* s = text.c_str();
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  if (end == s || !std::isfinite(v) || v <= 0)
    return invalidArgument("memory size '" + text + "': expected a positive number with an optional unit (e.g. 4G, 512M)");
  std::string unit(end);
  for (char& c : unit) c = char(std::tolower(static_cast<unsigned char>(c)));
  double mult = 1;
  if (unit.empty() || unit == "b") mult = 1;
  else if (unit == "k" || unit == "kb" || unit == "kib") mult = 1024.0;
  else if (unit == "m" || unit == "mb" || unit == "mib") mult = 1024.0 * 1024;
  else if (unit == "g" || unit == "gb" || unit == "gib") mult = 1024.0 * 1024 * 1024;
  else if (unit == "t" || unit == "tb" || unit == "tib") mult = 1024.0 * 1024 * 1024 * 1024;
  else return invalidArgument("memory size '" + text + "': unknown unit '" + std::string(end) + "' (use k, M, G or T)");
  const double bytes = v * mult;
  if (bytes > 1.8e19) return invalidArgument("memory size '" + text + "' is too large");
  return std::uint64_t(bytes);
}

std::string formatBytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024.0 && u < 6) { bytes /= 1024.0; ++u; }
  char buf[64];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return buf;
}

Status MemoryBudget::check(double bytes, const std::string& what, const std::string& how) const {
  if (bytes <= double(max_bytes)) return {};
  return outOfRange(what + " would need about " + formatBytes(bytes) + " of memory (limit " +
                    formatBytes(double(max_bytes)) + ", --max-memory); " + how);
}

double estimateOctreeBytes(double nodes) { return nodes * kOctreeBytesPerNode; }

double estimateSurveyParseBytes(const std::string& text) {
  // A token is a run of characters that are not YAML punctuation or blanks; comments are skipped.
  double tokens = 0;
  bool in_token = false, in_comment = false;
  for (const char c : text) {
    if (in_comment) {
      if (c == '\n') in_comment = false;
      continue;
    }
    const bool sep = c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == ',' || c == '[' || c == ']' ||
                     c == '{' || c == '}' || c == ':';
    if (c == '#' && !in_token) { in_comment = true; continue; }
    if (!sep && !in_token) ++tokens;
    in_token = !sep;
  }
  return double(text.size()) + tokens * kYamlBytesPerToken;
}

double estimateVoxelizeBytes(const SurveyNetwork& network) {
  return network.estimatedVoxels() * kOctreeBuildBytesPerVoxel;
}

double distanceFieldBytesPerTile() {
  // A block whose tiles are all allocated, its record and coordinates, the build's bit set and
  // hash-map entry for it.
  return double(kBlockVoxels) * 4.0 + kBlockBytes + 512.0 + 48.0;
}

DistanceFieldEstimate estimateDistanceField(const OccupancyMap& map) {
  DistanceFieldEstimate e;
  const octomap::OcTree& tree = map.octree();
  const unsigned depth = tree.getTreeDepth();
  int lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
  if (map.unknownPolicy() == UnknownPolicy::kFree) {
    // The field fills the whole bounding box (as DistanceField::build does).
    const Aabb b = map.bounds();
    if (b.empty()) return e;
    const double res = map.resolution(), inv = 1.0 / res;
    double tiles = 1, cell_tiles = 1;
    for (int a = 0; a < 3; ++a) {
      const int k0 = internal::keyOf(b.min[a] + 0.5 * res, inv), k1 = internal::keyOf(b.max[a] - 0.5 * res, inv);
      const double n = std::ceil((k1 - k0 + 1) / 16.0 + 1);
      tiles *= n;
      cell_tiles *= double((k1 >> kTileBits) - (k0 >> kTileBits) + 1);  // those the box touches
    }
    e.tiles = std::uint64_t(tiles);
    e.index_cells = e.tiles;
    e.cell_tiles = std::uint64_t(cell_tiles);
  } else {
    std::unordered_set<std::uint64_t> small_tiles, small_cell_tiles;
    std::uint64_t big_tiles = 0, big_cell_tiles = 0;
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      if (tree.isNodeOccupied(*it)) continue;
      const int size = 1 << (depth - it.getDepth());
      const octomap::OcTreeKey& k = it.getKey();
      int l[3];
      for (int a = 0; a < 3; ++a) l[a] = int(k[a]) & ~(size - 1);
      int t0[3], t1[3];
      for (int a = 0; a < 3; ++a) {
        t0[a] = l[a] >> internal::kBlockBits;
        t1[a] = (l[a] + size - 1) >> internal::kBlockBits;
        lo[a] = std::min(lo[a], t0[a]);
        hi[a] = std::max(hi[a], t1[a]);
      }
      if (size >= internal::kBlockSize) {
        const std::uint64_t n = std::uint64_t(size / internal::kBlockSize);
        big_tiles += n * n * n;  // aligned: these tiles hold no other leaf
      } else {
        small_tiles.insert(tileKey(t0[0], t0[1], t0[2]));
      }
      if (size >= (1 << kTileBits)) {
        const std::uint64_t n = std::uint64_t(size >> kTileBits);
        big_cell_tiles += n * n * n;
      } else {
        small_cell_tiles.insert(tileKey(l[0] >> kTileBits, l[1] >> kTileBits, l[2] >> kTileBits));
      }
    }
    e.tiles = big_tiles + small_tiles.size();
    e.cell_tiles = big_cell_tiles + small_cell_tiles.size();
    if (e.tiles > 0) {
      e.index_cells = 1;
      for (int a = 0; a < 3; ++a) e.index_cells *= std::uint64_t(hi[a] - lo[a] + 1);
    }
  }
  e.bytes = double(e.tiles) * kBlockBytes + double(e.cell_tiles) * kTileBytes + double(e.index_cells) * 4.0;
  return e;
}

double estimateFootprintBytes(const OccupancyMap& map) {
  const Aabb b = map.bounds();
  if (b.empty()) return 0.0;
  const double res = map.resolution();
  return std::round(b.size().x() / res) * std::round(b.size().y() / res) * 5.0;
}

namespace {

// Key range of the voxels whose centre lies in [lo, hi] on one axis; false when there is none.
bool keyRange(double lo, double hi, double res, int* k0, int* k1) {
  const double inv = 1.0 / res;
  const double lim = 32767.0 * res;
  lo = std::max(lo, -lim);
  hi = std::min(hi, lim);
  if (lo > hi) return false;
  *k0 = internal::keyOf(lo, inv);
  if (internal::centreOf(*k0, res) < lo) ++*k0;
  *k1 = internal::keyOf(hi, inv);
  if (internal::centreOf(*k1, res) > hi) --*k1;
  return *k0 <= *k1;
}

}  // namespace

double estimateCropBytes(const OccupancyMap& map, const Aabb& box) {
  const MapStats& s = map.stats();
  double box_voxels = 1;
  for (int a = 0; a < 3; ++a) {
    int k0 = 0, k1 = -1;
    if (!allFinite(box.min) || !allFinite(box.max) || !keyRange(box.min[a], box.max[a], map.resolution(), &k0, &k1))
      return 0.0;
    box_voxels *= double(k1 - k0 + 1);
  }
  const double known = double(s.free_voxels) + double(s.occupied_voxels);
  return std::min(box_voxels, known) * kOctreeBuildBytesPerVoxel;
}

StatusOr<Aabb> parseBox(const std::string& text) {
  std::string t = text;
  for (char& c : t)
    if (c == ',' || c == ';') c = ' ';
  std::istringstream is(t);
  double v[6];
  std::string tok;
  for (double& x : v) {
    if (!(is >> tok)) return invalidArgument("box '" + text + "': expected xmin,ymin,zmin,xmax,ymax,zmax");
    char* end = nullptr;
    x = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') return invalidArgument("box '" + text + "': '" + tok + "' is not a number");
    if (!std::isfinite(x)) return invalidArgument("box '" + text + "': '" + tok + "' is not finite");
  }
  if (is >> tok) return invalidArgument("box '" + text + "': more than six values");
  const Aabb box(Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5]));
  for (int a = 0; a < 3; ++a)
    if (box.min[a] > box.max[a])
      return invalidArgument("box '" + text + "': min is above max on axis " + std::string(1, "xyz"[a]));
  return box;
}

StatusOr<OccupancyMap> cropMap(const OccupancyMap& map, const Aabb& box) {
  if (!allFinite(box.min) || !allFinite(box.max) || (box.min.array() > box.max.array()).any())
    return invalidArgument("crop box must be finite with min <= max");
  const double res = map.resolution();
  int k0[3], k1[3];
  for (int a = 0; a < 3; ++a)
    if (!keyRange(box.min[a], box.max[a], res, &k0[a], &k1[a]))
      return failedPrecondition("crop box holds no voxel centre of the map's grid");
  const octomap::OcTree& tree = map.octree();
  const unsigned depth = tree.getTreeDepth();
  auto out = std::make_shared<octomap::OcTree>(res);
  std::uint64_t voxels = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const int size = 1 << (depth - it.getDepth());
    const octomap::OcTreeKey& k = it.getKey();
    int lo[3], hi[3];
    bool meets = true;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(int(k[a]) & ~(size - 1), k0[a]);
      hi[a] = std::min((int(k[a]) & ~(size - 1)) + size - 1, k1[a]);
      meets = meets && lo[a] <= hi[a];
    }
    if (!meets) continue;
    const float value = it->getLogOdds();
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          out->setNodeValue(octomap::OcTreeKey(octomap::key_type(x), octomap::key_type(y), octomap::key_type(z)), value,
                            /*lazy_eval=*/true);
          ++voxels;
        }
  }
  if (voxels == 0) return failedPrecondition("crop box holds no known (free or occupied) voxel of the map");
  out->updateInnerOccupancy();
  out->prune();
  return OccupancyMap::create(std::move(out), map.unknownPolicy());
}

}  // namespace adit::map
