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

// Speckle, a cable and a bump on the wall (one voxel thick) inside the generated tube, beside a
// pillar two voxels thick: noise points a merged scan leaves in an open roadway.
std::vector<Vec3> noise() {
  std::vector<Vec3> pts = {{3.1, 0.1, 1.5}, {5.1, -0.9, 2.1}, {9.3, 0.5, 0.7}, {6.1, 1.9, 1.5}};
  for (double x = 2.05; x < 10; x += 0.1) pts.emplace_back(x, 1.1, 2.5);  // a cable below the roof
  for (double z = 0.9; z < 1.3; z += 0.1) pts.emplace_back(4.1, -1.1, z);  // a short vertical stick
  return pts;
}

std::vector<Vec3> pillar() {  // 0.4 m x 0.4 m (2 x 2 voxels) from floor to roof at x = 8, y = -0.8
  std::vector<Vec3> pts;
  for (double x : {8.1, 8.3})
    for (double y : {-0.9, -0.7})
      for (double z = 0.05; z < 3.0; z += 0.1) pts.emplace_back(x, y, z);
  return pts;
}

std::uint64_t occupiedLeaves(const OccupancyMap& m) {
  std::uint64_t n = 0;
  m.forEachLeaf([&](const Vec3&, double size, VoxelState s) {
    if (s == VoxelState::kOccupied) n += std::uint64_t(std::llround(std::pow(size / m.resolution(), 3)));
  });
  return n;
}

TEST(FreeSpace, ThinRockIsClearedAndThickRockStays) {
  std::vector<Vec3> clean = TubeScan{}.points(), noisy;
  const std::vector<Vec3> p2 = pillar();
  clean.insert(clean.end(), p2.begin(), p2.end());
  noisy = clean;
  const std::vector<Vec3> n = noise();
  noisy.insert(noisy.end(), n.begin(), n.end());

  ImportParams off = seeded({6, 0, 1.5});
  off.thin_radius_m = 0.0;
  const ImportResult kept = importOrFail(cloud(noisy), off);
  EXPECT_EQ(kept.thin_cleared, 0u);
  EXPECT_EQ(kept.map.state({3.1, 0.1, 1.5}), VoxelState::kOccupied);
  EXPECT_EQ(kept.map.state({6.1, 1.1, 2.5}), VoxelState::kOccupied);

  // The default: one voxel. Every noise voxel goes, nothing else does: the cleaned map holds
  // exactly the rock of the scan without the noise (walls, floor, roof and the pillar).
  const ImportResult cleaned = importOrFail(cloud(noisy), seeded({6, 0, 1.5}));
  const ImportResult reference = importOrFail(cloud(clean), seeded({6, 0, 1.5}));
  EXPECT_EQ(reference.thin_cleared, 0u);
  EXPECT_EQ(cleaned.thin_cleared, cleaned.surface_voxels - reference.surface_voxels);
  EXPECT_GE(cleaned.thin_cleared, 40u + 4u + 2u);
  EXPECT_EQ(cleaned.free_voxels, reference.free_voxels);
  EXPECT_EQ(occupiedLeaves(cleaned.map), occupiedLeaves(reference.map));
  for (const Vec3& q : n) EXPECT_TRUE(cleaned.map.isFree(q)) << q.transpose();
  for (const Vec3& q : p2) EXPECT_EQ(cleaned.map.state(q), VoxelState::kOccupied) << q.transpose();
  const std::vector<Vec3> walls = TubeScan{}.points();
  std::size_t eroded = 0;
  for (const Vec3& q : walls) eroded += cleaned.map.state(q) != VoxelState::kOccupied;
  EXPECT_EQ(eroded, 0u);

  // A radius of two voxels also takes the two-voxel pillar (no thicker than 0.4 m), not the walls.
  ImportParams wide = seeded({6, 0, 1.5});
  wide.thin_radius_m = 0.4;
  const ImportResult wider = importOrFail(cloud(noisy), wide);
  EXPECT_GE(wider.thin_cleared, cleaned.thin_cleared + 4 * 12);
  EXPECT_TRUE(wider.map.isFree({8.1, -0.9, 1.5}));
  eroded = 0;
  for (const Vec3& q : walls) eroded += wider.map.state(q) != VoxelState::kOccupied;
  EXPECT_EQ(eroded, 0u);
}

TEST(FreeSpace, BadThinRadiusIsNamed) {
  for (double bad : {-0.1, std::nan(""), HUGE_VAL, 10.0}) {
    ImportParams p = seeded({6, 0, 1.5});
    p.thin_radius_m = bad;
    const Status s = p.validate();
    ASSERT_FALSE(s.ok()) << bad;
    EXPECT_NE(s.message().find("thin radius"), std::string::npos) << s.message();
  }
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
