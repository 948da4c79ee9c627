// SPDX-License-Identifier: BSD-3-Clause
// The real mines of ../shared/data (Jinchuan LiDAR PCD, Koutzi STL mesh) become navigable maps:
// one flood of free space runs from one roadway end to the other, and no free voxel lies outside
// the scanned hull (measured here independently of the importer: over each free voxel's column
// neighbourhood there must be scanned surface both above and below it). Compiled in only when
// the data is there (ADIT_HAVE_MINE_DATA), so a fresh clone has no such tests.
#include <gtest/gtest.h>

#ifdef ADIT_HAVE_MINE_DATA

#include <octomap/OcTree.h>

#include <cmath>
#include <deque>
#include <unordered_map>
#include <unordered_set>

#include "adit/map/free_space.hpp"
#include "adit/map/readers/import.hpp"

namespace adit::map {
namespace {

const std::string kData = ADIT_SHARED_DATA_DIR;

// Per 1 m column of the scan, the lowest and highest surface point.
class ColumnHull {
 public:
  explicit ColumnHull(const std::vector<Vec3>& surface) {
    for (const Vec3& p : surface) {
      auto& r = cols_.try_emplace(key(std::floor(p.x()), std::floor(p.y())), Range{p.z(), p.z()}).first->second;
      r.lo = std::min(r.lo, p.z());
      r.hi = std::max(r.hi, p.z());
    }
  }
  // Surface below and above c within the 3 x 3 columns around it.
  bool contains(const Vec3& c) const {
    bool below = false, above = false;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) {
        auto it = cols_.find(key(std::floor(c.x()) + dx, std::floor(c.y()) + dy));
        if (it == cols_.end()) continue;
        below |= it->second.lo <= c.z();
        above |= it->second.hi >= c.z();
      }
    return below && above;
  }

 private:
  struct Range {
    double lo, hi;
  };
  static std::int64_t key(double x, double y) { return (std::int64_t(x) + (1 << 20)) * (1 << 21) + std::int64_t(y) + (1 << 20); }
  std::unordered_map<std::int64_t, Range> cols_;
};

struct FloodCheck {
  std::uint64_t free = 0, reached = 0, outside_hull = 0, outside_box = 0;
  Vec3 west, east;  // free voxel centres with the least / greatest x
};

// Expands every free leaf to finest voxels, then floods 6-connected from the westmost one.
FloodCheck check(const OccupancyMap& map, const ColumnHull& hull, const Aabb& box) {
  const octomap::OcTree& tree = map.octree();
  const double res = map.resolution();
  std::unordered_set<std::uint64_t> free;
  auto pack = [](const octomap::OcTreeKey& k) {
    return (std::uint64_t(k[0]) << 32) | (std::uint64_t(k[1]) << 16) | std::uint64_t(k[2]);
  };
  FloodCheck out;
  out.west = Vec3::Constant(1e300);
  out.east = Vec3::Constant(-1e300);
  octomap::OcTreeKey west_key;
  map.forEachLeaf([&](const Vec3& c, double size, VoxelState s) {
    if (s != VoxelState::kFree) return;
    const int n = int(std::lround(size / res));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          const Vec3 v = c - Vec3::Constant(0.5 * size) + res * Vec3(i + 0.5, j + 0.5, k + 0.5);
          const octomap::OcTreeKey key = tree.coordToKey(v.x(), v.y(), v.z());
          free.insert(pack(key));
          ++out.free;
          if (!hull.contains(v)) ++out.outside_hull;
          if (!box.contains(v)) ++out.outside_box;
          if (v.x() < out.west.x()) { out.west = v; west_key = key; }
          if (v.x() > out.east.x()) out.east = v;
        }
  });
  std::unordered_set<std::uint64_t> seen{pack(west_key)};
  std::deque<octomap::OcTreeKey> queue{west_key};
  while (!queue.empty()) {
    const octomap::OcTreeKey k = queue.front();
    queue.pop_front();
    for (int axis = 0; axis < 3; ++axis)
      for (int d : {-1, 1}) {
        octomap::OcTreeKey m = k;
        m[axis] = octomap::key_type(int(m[axis]) + d);
        if (free.count(pack(m)) && seen.insert(pack(m)).second) queue.push_back(m);
      }
  }
  out.reached = seen.size();
  return out;
}

// Reads a Jinchuan PCD, floods it from `seed` and checks the result against its own points.
FloodCheck importJinchuan(const std::string& file, std::size_t points, double res, const Vec3& seed) {
  StatusOr<Geometry> g = readGeometry(kData + "/jinchuan_mine_pcd/" + file);
  EXPECT_TRUE(g.ok()) << g.status().message();
  if (!g.ok()) return {};
  EXPECT_EQ(g->points.size(), points);
  ImportParams p;
  p.resolution_m = res;
  p.seed = seed;
  StatusOr<ImportResult> r = buildMapFromGeometry(*g, p);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) return {};
  Aabb box;
  for (const Vec3& q : g->points) box.extend(q);
  return check(r->map, ColumnHull(g->points), box.inflated(res));
}

TEST(RealMineData, JinchuanRegisteredCloudIsOneNavigableNetwork) {
  // The registered merge is sparse (~100-600 points per metre of roadway): 0.5 m voxels.
  const FloodCheck c = importJinchuan("21_all_25_all.pcd", 98802, 0.5, {10, 0.8, 1.0});
  ASSERT_GT(c.free, 0u);
  EXPECT_EQ(c.outside_box, 0u);
  EXPECT_EQ(c.outside_hull, 0u);
  EXPECT_EQ(c.reached, c.free) << "free space is not one connected region";
  // From the west end of the main roadway (x ~ -20) to the loop at the east end (x ~ 265).
  EXPECT_LT(c.west.x(), -12.0);
  EXPECT_GT(c.east.x(), 255.0);
  // The volume is a roadway network's, not a leak into the box (300 x 240 x 115 m).
  EXPECT_GT(double(c.free) * 0.125, 3000.0);
  EXPECT_LT(double(c.free) * 0.125, 15000.0);
}

TEST(RealMineData, JinchuanRawCompressedScanConverts) {
  // One raw survey, PCD binary_compressed.
  const FloodCheck c = importJinchuan("2025-04-21-11-04-46.pcd", 176758, 0.3, {10, -2, 0});
  ASSERT_GT(c.free, 0u);
  EXPECT_EQ(c.outside_box, 0u);
  EXPECT_EQ(c.outside_hull, 0u);
  EXPECT_EQ(c.reached, c.free);
  EXPECT_LT(c.west.x(), -5.0);  // the west end of the survey's drift
  EXPECT_GT(c.east.x(), 65.0);  // and its east end
}

TEST(RealMineData, KoutziMeshIsOneNavigableNetwork) {
  StatusOr<Geometry> g = readGeometry(kData + "/koutzi_mine_mesh/GM-KUM.stl");
  ASSERT_TRUE(g.ok()) << g.status().message();
  ASSERT_EQ(g->triangles.size(), 26873u);
  ImportParams p;
  p.resolution_m = 0.2;
  p.seed = Vec3(0, 0, 2);
  StatusOr<ImportResult> r = buildMapFromGeometry(*g, p);
  ASSERT_TRUE(r.ok()) << r.status().message();
  // The hull from the mesh surface itself (its voxels' centres), not from the vertices.
  StatusOr<std::vector<VoxelKey>> keys = meshVoxelKeys(*g, p.resolution_m);
  ASSERT_TRUE(keys.ok());
  std::vector<Vec3> surface;
  octomap::OcTree keyer(p.resolution_m);
  for (const VoxelKey& k : *keys) {
    const octomap::point3d c = keyer.keyToCoord(octomap::OcTreeKey(k[0], k[1], k[2]));
    surface.emplace_back(c.x(), c.y(), c.z());
  }
  Aabb box;
  for (const Vec3& q : g->points) box.extend(q);
  const FloodCheck c = check(r->map, ColumnHull(surface), box.inflated(p.resolution_m));
  EXPECT_EQ(c.outside_box, 0u);
  EXPECT_EQ(c.outside_hull, 0u);
  EXPECT_EQ(c.reached, c.free);
  EXPECT_LT(c.west.x(), -10.0);  // west end of the main drift (x ~ -13)
  EXPECT_GT(c.east.x(), 93.0);   // top of the inclined branch (x ~ 96)
}

}  // namespace
}  // namespace adit::map

#endif  // ADIT_HAVE_MINE_DATA
