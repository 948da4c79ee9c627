// SPDX-License-Identifier: BSD-3-Clause
// Free-space recovery on generated scans with known insides: the flood fills the roadway, stays
// inside walls, roof, floor and the input's box, does not leak through holes, and every way a
// seed can be wrong is named.
#include <gtest/gtest.h>

#include <cmath>

#include "adit/map/free_space.hpp"
#include "support/synthetic_scan.hpp"

namespace adit::map {
namespace {

using test::TubeScan;

Geometry cloud(const std::vector<Vec3>& pts) {
  Geometry g;
  g.points = pts;
  return g;
}

ImportResult importOrFail(const Geometry& g, const ImportParams& p) {
  StatusOr<ImportResult> r = buildMapFromGeometry(g, p);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) std::abort();
  return std::move(*r);
}

ImportParams seeded(const Vec3& seed, double res = 0.2) {
  ImportParams p;
  p.resolution_m = res;
  p.seed = seed;
  return p;
}

// Free voxels by brute force over the leaves, each checked by `inside`.
std::uint64_t countFreeOutside(const OccupancyMap& m, const std::function<bool(const Vec3&)>& inside) {
  std::uint64_t bad = 0;
  m.forEachLeaf([&](const Vec3& c, double, VoxelState s) {
    if (s == VoxelState::kFree && !inside(c)) ++bad;
  });
  return bad;
}

TEST(FreeSpace, SeedFloodFillsTheTubeAndNothingElse) {
  TubeScan t;
  const ImportResult r = importOrFail(cloud(t.points()), seeded({6, 0, 1.5}));
  EXPECT_EQ(r.source, FreeSpaceSource::kSeedFlood);
  // Inside voxels: x in (0, 12), |y| < 2, z in (0, 3) less the wall voxels (about 60 x 19 x 14).
  EXPECT_GT(r.free_voxels, 14000u);
  EXPECT_LT(r.free_voxels, 17000u);
  EXPECT_TRUE(r.map.isFree({6, 0, 1.5}));
  EXPECT_TRUE(r.map.isFree({0.3, 1.5, 2.5}));
  EXPECT_EQ(countFreeOutside(r.map, [&](const Vec3& c) {
              return c.x() > -0.2 && c.x() < 12.2 && std::abs(c.y()) < 2.0 && c.z() > 0 && c.z() < 3.0;
            }),
            0u);
  EXPECT_EQ(r.map.state({6, 0, 0.05}), VoxelState::kOccupied);
}

TEST(FreeSpace, NoLeakThroughAHoleInTheWall) {
  TubeScan t;
  t.hole_x0 = 4;
  t.hole_x1 = 7;
  t.hole_z0 = 0.5;
  t.hole_z1 = 2.5;  // a 3 m x 2 m window in the +y wall
  const ImportResult r = importOrFail(cloud(t.points()), seeded({6, 0, 1.5}));
  EXPECT_EQ(countFreeOutside(r.map, [](const Vec3& c) { return c.y() < 2.2; }), 0u);
  EXPECT_FALSE(r.map.isFree({6, 2.7, 1.5}));
  EXPECT_TRUE(r.map.isFree({5.5, 1.5, 1.5}));  // in front of the hole: still roadway
  EXPECT_TRUE(r.map.isFree({11, 0, 1.5}));     // and past it
}

TEST(FreeSpace, ClosingPlugsASmallHole) {
  TubeScan t;
  t.hole_x0 = 5.95;
  t.hole_x1 = 6.25;
  t.hole_z0 = 1.35;
  t.hole_z1 = 1.65;  // a 0.3 m hole
  ImportParams p = seeded({6, 0, 1.5});
  p.closing_radius_m = 0.4;
  const ImportResult r = importOrFail(cloud(t.points()), p);
  EXPECT_GT(r.closed_voxels, 0u);
  EXPECT_EQ(r.map.state({6.1, 2.0, 1.5}), VoxelState::kOccupied);
  EXPECT_TRUE(r.map.isFree({6, 0, 1.5}));
}

TEST(FreeSpace, OpenEndsDoNotLetFreeSpaceOutOfTheBox) {
  // The L's legs end open; the flood stops at the scanned extent.
  const auto pts = test::lScan();
  const ImportResult r = importOrFail(cloud(pts), seeded({2, 0, 1.5}));
  Aabb box;
  for (const Vec3& p : pts) box.extend(p);
  EXPECT_EQ(countFreeOutside(r.map, [&](const Vec3& c) { return box.contains(c); }), 0u);
  // Both ends reached: the far end of leg 2 is free.
  EXPECT_TRUE(r.map.isFree({10, 11.5, 1.5}));
  // The rock inside the L's corner is not.
  EXPECT_FALSE(r.map.isFree({4, 6, 1.5}));
}

TEST(FreeSpace, MeshTubeIsFilledLikeTheScan) {
  TubeScan t;
  const ImportResult r = importOrFail(t.mesh(), seeded({6, 0, 1.5}));
  EXPECT_EQ(r.inputs, 8u);
  EXPECT_GT(r.free_voxels, 14000u);
  EXPECT_LT(r.free_voxels, 17000u);
}

TEST(FreeSpace, TrajectoryRaysClearTheSeenSpace) {
  TubeScan t;
  ImportParams p;
  p.resolution_m = 0.2;
  for (double x = 0.5; x < 12; x += 1.0) p.trajectory.emplace_back(x, 0, 1.5);
  const ImportResult r = importOrFail(cloud(t.points()), p);
  EXPECT_EQ(r.source, FreeSpaceSource::kTrajectoryRays);
  EXPECT_GT(r.free_voxels, 10000u);
  EXPECT_TRUE(r.map.isFree({6.5, 0.1, 0.7}));  // under the pose at x = 6.5
  EXPECT_EQ(countFreeOutside(r.map, [&](const Vec3& c) {
              return std::abs(c.y()) < 2.0 && c.z() > 0 && c.z() < 3.0;
            }),
            0u);
}

TEST(FreeSpace, BadSeedsAreNamed) {
  const Geometry g = cloud(TubeScan{}.points());
  auto err = [&](const Vec3& seed, double wall = 5.0) {
    ImportParams p = seeded(seed);
    p.max_wall_distance_m = wall;
    StatusOr<ImportResult> r = buildMapFromGeometry(g, p);
    return r.ok() ? std::string("ok") : r.status().message();
  };
  EXPECT_NE(err({6, 0, 50}).find("outside the input's bounding box"), std::string::npos) << err({6, 0, 50});
  EXPECT_NE(err({6, 0, 0.05}).find("surface voxel"), std::string::npos);
  EXPECT_NE(err({6, 0, 1.5}, 0.6).find("farther than"), std::string::npos);
  EXPECT_NE(err({-0.5, 0, 1.5}).find("outside the input's bounding box"), std::string::npos);
  ImportParams corner = seeded({4, 6, 1.5});  // rock inside the L's corner: no roof above it
  const std::string hull = buildMapFromGeometry(cloud(test::lScan()), corner).status().message();
  EXPECT_NE(hull.find("hull"), std::string::npos) << hull;
  ImportParams none;
  EXPECT_NE(buildMapFromGeometry(g, none).status().message().find("--seed"), std::string::npos);
}

TEST(FreeSpace, MemoryBudgetIsEstimatedAndRefused) {
  ImportParams p = seeded({6, 0, 1.5});
  p.max_memory_bytes = 30000;
  StatusOr<ImportResult> r = buildMapFromGeometry(cloud(TubeScan{}.points()), p);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kOutOfRange);
  EXPECT_NE(r.status().message().find("MiB"), std::string::npos) << r.status().message();
  // A box far larger than any budget is refused before allocating its tables.
  Geometry far = cloud({{0, 0, 0}, {3000, 3000, 3000}});
  p.max_memory_bytes = std::uint64_t{1} << 30;
  p.resolution_m = 0.1;
  r = buildMapFromGeometry(far, p);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("voxels"), std::string::npos) << r.status().message();
}

TEST(FreeSpace, VoxelKeysAreDeduplicated) {
  const std::vector<Vec3> pts = {{0.01, 0.01, 0.01}, {0.02, 0.03, 0.04}, {0.5, 0, 0}};
  EXPECT_EQ(occupiedVoxelKeys(pts, 0.2).size(), 2u);
  Geometry huge = TubeScan{}.mesh();
  EXPECT_FALSE(meshVoxelKeys(huge, 0.001, 1000).ok());
}

// auto_seed on two tubes stacked 5 m apart: the rock between them has scanned surface above and
// below and lies farther from it (2.5 m) than any point inside a tube (1.5 m), but has no walls
// beside it; the chosen seed is inside a tube and floods it, and errors name a given seed as
// seed_name says.
TEST(FreeSpace, AutoSeedChoosesARoadwayNotTheRockBetweenLevels) {
  TubeScan t;
  std::vector<Vec3> pts = t.points();
  for (const Vec3& q : t.points()) pts.push_back(q + Vec3(0, 0, 8));
  ImportParams p;
  p.resolution_m = 0.25;
  p.auto_seed = true;
  const ImportResult r = importOrFail(cloud(pts), p);
  ASSERT_TRUE(r.seed.has_value());
  const Vec3 s = *r.seed;
  EXPECT_TRUE(s.x() > 0 && s.x() < 12 && std::abs(s.y()) < 2 && ((s.z() > 0 && s.z() < 3) || (s.z() > 8 && s.z() < 11)))
      << s.transpose();
  EXPECT_TRUE(r.map.isFree(s));
  EXPECT_FALSE(r.map.isFree({6, 0, 5.5}));  // the rock between the levels stays unknown
  EXPECT_GT(r.free_voxels, 5000u);

  ImportParams named = seeded({6, 0, 0.05}, 0.25);
  named.seed_name = "500006,4000000,800.05";
  const StatusOr<ImportResult> bad = buildMapFromGeometry(cloud(pts), named);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("seed 500006,4000000,800.05 lies in a surface voxel"), std::string::npos)
      << bad.status().message();
}

}  // namespace
}  // namespace adit::map
