// SPDX-License-Identifier: BSD-3-Clause
// Oracle tests: the distance field against brute force over every rock voxel.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <random>

#include "adit/map/brute_force_distance.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

using Case = test::NamedNetwork;

std::vector<Case> oracleCases() { return test::oracleRoadways(10.0); }

class DistanceFieldOracle : public ::testing::TestWithParam<std::size_t> {};

// Half a voxel: the field is exact at voxel centres; between them it reads the nearest rock of
// the 8 surrounding voxels, whose error is a fraction of a voxel.
TEST_P(DistanceFieldOracle, MatchesBruteForceWithinHalfAVoxel) {
  const Case c = oracleCases()[GetParam()];
  const OccupancyMap map = test::voxelizeOrFail(c.net);
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok()) << df.status().toString();
  StatusOr<BruteForceDistance> oracle = BruteForceDistance::create(map);
  ASSERT_TRUE(oracle.ok());
  const double res = map.resolution();
  std::mt19937_64 rng(42);
  int free_points = 0;
  double max_err = 0;
  for (int i = 0; i < 1500; ++i) {
    const Vec3 p = test::randomPoint(rng, map.bounds());
    const DistanceSample a = df->query(p), b = oracle->query(p);
    ASSERT_EQ(a.in_rock, b.in_rock) << c.name << " at " << p.transpose();
    EXPECT_NEAR(a.distance, b.distance, 0.5 * res) << c.name << " at " << p.transpose();
    max_err = std::max(max_err, std::abs(a.distance - b.distance));
    EXPECT_GE(a.distance + 1e-9, b.distance) << "field must never be closer than the nearest rock";
    EXPECT_LE(a.distance, b.distance + df->errorBound()) << "beyond the proven bound at " << p.transpose();
    if (!a.in_rock) {
      ++free_points;
      if (a.distance > 1e-6) {
        EXPECT_NEAR(a.gradient.norm(), 1.0, 1e-9);
        // The closest point is on rock and the gradient points from it to p.
        EXPECT_FALSE(map.isFree(a.nearest - 1e-6 * a.gradient)) << p.transpose();
        EXPECT_LT((p - a.nearest - a.distance * a.gradient).norm(), 1e-9);
      }
    }
  }
  EXPECT_GT(free_points, 100) << c.name;
  RecordProperty("max_error_m", std::to_string(max_err));
  std::printf("max error %s: %.4f voxels\n", c.name, max_err / res);
}

TEST_P(DistanceFieldOracle, ExactAtVoxelCentres) {
  const Case c = oracleCases()[GetParam()];
  const OccupancyMap map = test::voxelizeOrFail(c.net);
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  StatusOr<BruteForceDistance> oracle = BruteForceDistance::create(map);
  ASSERT_TRUE(oracle.ok());
  const double res = map.resolution();
  std::mt19937_64 rng(7);
  for (int i = 0; i < 800; ++i) {
    Vec3 p = test::randomPoint(rng, map.bounds());
    p = ((p / res).array().floor() + 0.5) * res;  // snap to a voxel centre
    // The stored feature is the nearest rock voxel centre-to-centre; compare that exactly.
    if (!map.isFree(p)) continue;
    const Vec3 site = df->nearestRockVoxel(p);
    double best = 1e300;
    for (const Vec3& r : oracle->rockCentres()) best = std::min(best, (r - p).norm());
    EXPECT_NEAR((site - p).norm(), best, 1e-9) << p.transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(Roadways, DistanceFieldOracle, ::testing::Range<std::size_t>(0, 4),
                         [](const ::testing::TestParamInfo<std::size_t>& i) { return std::string(oracleCases()[i.param].name); });

TEST(DistanceField, WindowUpdateMatchesFullRebuild) {
  OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.25));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  // Rubble: a 1 m block in the main roadway, then part of it cleared and a wall opened.
  std::vector<Vec3> rubble, cleared;
  for (double x = 3.0; x < 4.0; x += 0.25)
    for (double y = -0.5; y < 0.5; y += 0.25)
      for (double z = 0.1; z < 1.1; z += 0.25) rubble.push_back({x, y, z});
  ASSERT_TRUE(map.setVoxels(rubble, VoxelState::kOccupied).ok());
  ASSERT_TRUE(df->update(map, Aabb({3.0, -0.5, 0.1}, {4.0, 0.5, 1.1})).ok());
  for (double y = 2.0; y < 3.5; y += 0.25)
    for (double z = 0.2; z < 2.0; z += 0.25) cleared.push_back({10.0, y, z});
  ASSERT_TRUE(map.setVoxels(cleared, VoxelState::kFree).ok());
  ASSERT_TRUE(df->update(map, Aabb({10.0, 2.0, 0.2}, {10.25, 3.5, 2.0})).ok());

  StatusOr<DistanceField> fresh = DistanceField::build(map);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(df->stats().free_voxels, fresh->stats().free_voxels);
  std::mt19937_64 rng(3);
  for (int i = 0; i < 4000; ++i) {
    const Vec3 p = test::randomPoint(rng, map.bounds());
    ASSERT_EQ(df->isFree(p), fresh->isFree(p)) << p.transpose();
    EXPECT_NEAR(df->distance(p), fresh->distance(p), 1e-9) << p.transpose();
  }
  EXPECT_FALSE(df->isFree({3.5, 0.0, 0.5}));
  EXPECT_TRUE(df->isFree({10.1, 2.6, 1.0}));
}

// Windowed updates give exactly a fresh build's field: the same nearest rock voxel at every voxel
// centre of the map (not only the same distance: the site decides the gradient), after each of a
// sequence of rubble falls and clearings of random sizes at random places. The voxels a change
// reaches lie within the field's largest clearance of it; a write box one voxel short of that
// fails here.
TEST(DistanceField, WindowUpdatesGiveAFreshBuildsSitesEverywhere) {
  OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.25));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  const double res = map.resolution();
  const Aabb bounds = map.bounds();
  std::mt19937_64 rng(17);
  std::vector<Vec3> placed;  // rubble so far, for clearings that free some of it
  int compared = 0;
  for (int round = 0; round < 10; ++round) {
    const bool clear = round % 3 == 2 && !placed.empty();
    Vec3 at = clear ? placed[rng() % placed.size()] : test::randomPoint(rng, bounds);
    while (!clear && !map.isFree(at)) at = test::randomPoint(rng, bounds);  // rubble falls in the roadways
    std::uniform_int_distribution<int> extent(0, 4);
    const int nx = extent(rng), ny = extent(rng), nz = extent(rng);
    std::vector<Vec3> voxels;
    for (int i = 0; i <= nx; ++i)
      for (int j = 0; j <= ny; ++j)
        for (int k = 0; k <= nz; ++k) voxels.push_back(at + res * Vec3(i, j, k));
    MapChange change;
    ASSERT_TRUE(map.setVoxels(voxels, clear ? VoxelState::kFree : VoxelState::kOccupied, &change).ok());
    if (!clear) placed.insert(placed.end(), voxels.begin(), voxels.end());
    ASSERT_FALSE(change.empty());
    ++compared;
    ASSERT_TRUE(df->update(map, change.box).ok());
    StatusOr<DistanceField> fresh = DistanceField::build(map);
    ASSERT_TRUE(fresh.ok());
    const Vec3 lo = bounds.min.array() + 0.5 * res;
    for (double z = lo.z(); z < bounds.max.z(); z += res)
      for (double y = lo.y(); y < bounds.max.y(); y += res)
        for (double x = lo.x(); x < bounds.max.x(); x += res) {
          const Vec3 c(x, y, z);
          ASSERT_EQ(df->isFree(c), fresh->isFree(c)) << "round " << round << " at " << c.transpose();
          if (fresh->isFree(c))
            ASSERT_EQ(df->nearestRockVoxel(c), fresh->nearestRockVoxel(c)) << "round " << round << " at " << c.transpose();
        }
  }
  EXPECT_EQ(compared, 10);
}

// The tight case of that bound: the voxel farthest from rock (D voxels, its nearest rock voxel
// unique and straight across) loses its nearest rock, which is D voxels from it along an axis.
// The update must reach D voxels from the change, and no fewer will do.
TEST(DistanceField, WindowUpdateReachesTheFarthestVoxelWhoseRockIsCleared) {
  constexpr int kD = 6;
  const double res = 0.2;
  std::vector<Vec3> free;
  auto centre = [res](int x, int y, int z) { return Vec3((x + 0.5) * res, (y + 0.5) * res, (z + 0.5) * res); };
  // 30 voxels long, 2D wide (so each middle column has one nearest wall), 2D + 4 high (floor and
  // roof farther than the walls).
  for (int x = 0; x < 30; ++x)
    for (int y = 0; y < 2 * kD; ++y)
      for (int z = 0; z < 2 * kD + 4; ++z) free.push_back(centre(x, y, z));
  StatusOr<OccupancyMap> map = OccupancyMap::fromVoxels(res, free, {});
  ASSERT_TRUE(map.ok());
  StatusOr<DistanceField> df = DistanceField::build(*map);
  ASSERT_TRUE(df.ok());
  ASSERT_NEAR(df->stats().max_distance_m, kD * res, 1e-9);
  const Vec3 p = centre(15, kD - 1, kD + 2), wall = centre(15, -1, kD + 2);
  ASSERT_EQ(df->nearestRockVoxel(p), wall);
  MapChange change;
  ASSERT_TRUE(map->setVoxels({wall}, VoxelState::kFree, &change).ok());
  ASSERT_EQ(change.to_free, 1u);
  // The window as tight as it goes: inside the one voxel (the change's box is its closed cube,
  // whose far faces touch the next voxels).
  ASSERT_TRUE(df->update(*map, Aabb(wall - Vec3::Constant(0.25 * res), wall + Vec3::Constant(0.25 * res))).ok());
  StatusOr<DistanceField> fresh = DistanceField::build(*map);
  ASSERT_TRUE(fresh.ok());
  EXPECT_NE(fresh->nearestRockVoxel(p), wall);
  EXPECT_EQ(df->nearestRockVoxel(p), fresh->nearestRockVoxel(p));
  EXPECT_EQ(df->distance(p), fresh->distance(p));
}

// A change in a narrow roadway rewrites the voxels within the roadway's clearances of it, not
// within the largest clearance of the map (a chamber's): update() reads how far the change can
// reach from the clearances around it. The field stays a fresh build's, site for site, after
// rubble falls and clearings in the roadway, at its mouth, in the chamber and across both.
TEST(DistanceField, WindowUpdatesInARoadwayReachOnlyItsClearance) {
  const double res = 0.2;
  auto centre = [res](int x, int y, int z) { return Vec3((x + 0.5) * res, (y + 0.5) * res, (z + 0.5) * res); };
  std::vector<Vec3> free;
  // A roadway 4 voxels wide and 5 high, 60 long, opening into a 24-voxel chamber: the map's
  // largest clearance is the chamber's 12 voxels, the roadway's 2 to 3.
  for (int x = 0; x < 60; ++x)
    for (int y = 0; y < 4; ++y)
      for (int z = 0; z < 5; ++z) free.push_back(centre(x, y, z));
  for (int x = 60; x < 84; ++x)
    for (int y = -10; y < 14; ++y)
      for (int z = -8; z < 16; ++z) free.push_back(centre(x, y, z));
  StatusOr<OccupancyMap> map = OccupancyMap::fromVoxels(res, free, {});
  ASSERT_TRUE(map.ok());
  StatusOr<DistanceField> df = DistanceField::build(*map);
  ASSERT_TRUE(df.ok());
  const int grow_max = int(std::floor(df->stats().max_distance_m / res + 1e-9));
  ASSERT_GE(grow_max, 11);

  std::mt19937_64 rng(29);
  std::vector<Vec3> placed;
  int narrow = 0;
  for (int round = 0; round < 24; ++round) {
    const bool clear = round % 4 == 3 && !placed.empty();
    // Rubble up to 3 voxels on a side, every other fall deep in the roadway, the others anywhere
    // up to 10 voxels into the chamber; a clearing frees some of what fell.
    Vec3 at;
    if (clear) {
      at = placed[rng() % placed.size()];
    } else {
      do {
        at = round % 2 == 0 ? centre(int(rng() % 55), int(rng() % 4), int(rng() % 5))
                            : centre(int(rng() % 70), int(rng() % 20) - 8, int(rng() % 20) - 6);
      } while (!map->isFree(at));
    }
    std::vector<Vec3> voxels;
    const int n[3] = {int(rng() % 3), int(rng() % 3), int(rng() % 3)};
    for (int i = 0; i <= n[0]; ++i)
      for (int j = 0; j <= n[1]; ++j)
        for (int k = 0; k <= n[2]; ++k) voxels.push_back(at + res * Vec3(i, j, k));
    MapChange change;
    ASSERT_TRUE(map->setVoxels(voxels, clear ? VoxelState::kFree : VoxelState::kOccupied, &change).ok());
    if (change.empty()) continue;
    if (!clear) placed.insert(placed.end(), voxels.begin(), voxels.end());
    DistanceFieldUpdateReport report;
    ASSERT_TRUE(df->update(*map, change.box, &report).ok());
    ASSERT_FALSE(report.full_rebuild || report.full_transform);
    // The write box against the change grown by the map's largest clearance.
    const Vec3 extent = change.box.size() / res;
    double global = 1.0;
    for (int a = 0; a < 3; ++a) global *= std::floor(extent[a]) + 1.0 + 2.0 * grow_max;
    if (at.x() < 55 * res && double(report.voxels_recomputed) < 0.5 * global) ++narrow;

    StatusOr<DistanceField> fresh = DistanceField::build(*map);
    ASSERT_TRUE(fresh.ok());
    for (int z = -10; z < 18; ++z)
      for (int y = -12; y < 16; ++y)
        for (int x = -2; x < 86; ++x) {
          const Vec3 c = centre(x, y, z);
          ASSERT_EQ(df->isFree(c), fresh->isFree(c)) << "round " << round << " at " << c.transpose();
          if (fresh->isFree(c)) {
            ASSERT_EQ(df->nearestRockVoxel(c), fresh->nearestRockVoxel(c)) << "round " << round << " at " << c.transpose();
          }
        }
  }
  // Changes deep in the roadway rewrote less than half the globally bounded box (a twentieth,
  // measured).
  EXPECT_GE(narrow, 5);
}

// freeVoxels() reads what isFree() says at every voxel centre of a box, whatever the box's
// alignment to the tiles, its size, or whether it leaves the map (and the key range); distance()
// is query()'s distance.
TEST(DistanceField, FreeVoxelsAndDistanceAgreeWithIsFreeAndQuery) {
  const OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.25));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  const double res = map.resolution();
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<int> size(1, 19);
  auto check = [&](const std::int64_t lo[3], const std::int64_t n[3]) {
    std::vector<std::uint8_t> out(std::size_t(n[0] * n[1] * n[2]), 7);
    df->freeVoxels(lo, n, out.data());
    for (std::int64_t k = 0; k < n[2]; ++k)
      for (std::int64_t j = 0; j < n[1]; ++j)
        for (std::int64_t i = 0; i < n[0]; ++i) {
          const Vec3 c((double(lo[0] + i) + 0.5) * res, (double(lo[1] + j) + 0.5) * res, (double(lo[2] + k) + 0.5) * res);
          ASSERT_EQ(out[std::size_t(i + n[0] * (j + n[1] * k))], df->isFree(c) ? 1 : 0) << c.transpose();
        }
  };
  int free_seen = 0;
  for (int t = 0; t < 200; ++t) {
    const Vec3 at = test::randomPoint(rng, map.bounds());
    const std::int64_t lo[3] = {std::int64_t(std::floor(at.x() / res)) - 3, std::int64_t(std::floor(at.y() / res)) - 3,
                                std::int64_t(std::floor(at.z() / res)) - 3};
    const std::int64_t n[3] = {size(rng), size(rng), size(rng)};
    check(lo, n);
    free_seen += df->isFree(at) ? 1 : 0;
  }
  EXPECT_GT(free_seen, 10);
  // distance() is query()'s distance, bit for bit, in rock and out, and for NaN.
  for (int t = 0; t < 5000; ++t) {
    const Vec3 p = test::randomPoint(rng, map.bounds());
    ASSERT_EQ(df->distance(p), df->query(p).distance) << p.transpose();
  }
  EXPECT_EQ(df->distance(Vec3::Constant(std::nan(""))), df->query(Vec3::Constant(std::nan(""))).distance);
  // Across the ends of the key range: all rock there.
  for (const std::int64_t edge : {std::int64_t{-32768}, std::int64_t{32767}}) {
    const std::int64_t lo[3] = {edge - 5, -3, -3}, n[3] = {11, 7, 7};
    check(lo, n);
  }
}

// distance(p, cache) is distance(p) bit for bit: at random points and along a segment swept again
// and again with one end moved a little (as the refiner's finite differences do: nearly every read
// hits), on a field whose sites are in the far table, off the map, for NaN, and after the field
// changed under the cache (an update, then another field read through the same cache).
TEST(DistanceField, DistanceThroughAReadCacheIsDistanceBitForBit) {
  OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.25));
  StatusOr<DistanceField> near = DistanceField::build(map);
  StatusOr<DistanceField> far = DistanceField::buildWithNearLimitForTesting(map, 1);
  ASSERT_TRUE(near.ok() && far.ok());
  DistanceReadCache cache;
  std::mt19937_64 rng(31);
  auto sweep = [&](const DistanceField& f) {
    for (int t = 0; t < 3000; ++t) {
      const Vec3 p = test::randomPoint(rng, map.bounds());
      ASSERT_EQ(f.distance(p, cache), f.distance(p)) << p.transpose();
    }
    for (int seg = 0; seg < 20; ++seg) {
      const Vec3 a = test::randomPoint(rng, map.bounds()), b = test::randomPoint(rng, map.bounds());
      for (int round = 0; round < 6; ++round) {
        const Vec3 end = b + Vec3::Constant(1e-4 * (round % 3 - 1));
        for (int k = 0; k < 200; ++k) {
          const Vec3 q = a + (end - a) * ((k + 0.5) / 200);
          ASSERT_EQ(f.distance(q, cache), f.distance(q)) << q.transpose();
        }
      }
    }
    for (const Vec3& p : std::vector<Vec3>{Vec3::Constant(std::nan("")), Vec3(1e9, 0, 0), Vec3(-3276.9, 0.1, 0.1), Vec3(0, 0, -500)})
      ASSERT_EQ(f.distance(p, cache), f.distance(p)) << p.transpose();
  };
  sweep(*near);
  const std::uint64_t hits = cache.hits(), misses = cache.misses();
  EXPECT_GT(hits, 4 * misses) << "the repeated sweeps should read mostly from the cache";
  sweep(*far);
  EXPECT_GT(far->stats().far_sites, 0u);
  // Rubble across the junction: the cache must not answer with what it read before the update.
  std::vector<Vec3> rubble;
  for (double x = -1.0; x < 1.0; x += 0.25)
    for (double y = -1.0; y < 1.0; y += 0.25)
      for (double z = 0.1; z < 1.6; z += 0.25) rubble.push_back({x, y, z});
  for (int t = 0; t < 2000; ++t) (void)near->distance(Vec3(rng() % 200 * 0.01 - 1.0, rng() % 200 * 0.01 - 1.0, 1.0), cache);
  map.setVoxels(rubble, VoxelState::kOccupied);
  ASSERT_TRUE(near->update(map, Aabb({-1.0, -1.0, 0.1}, {1.0, 1.0, 1.6})).ok());
  for (double x = -1.0; x < 1.0; x += 0.05) {
    const Vec3 p(x, 0.05, 1.0);
    ASSERT_EQ(near->distance(p, cache), near->distance(p)) << p.transpose();
  }
  sweep(*near);
}

// Free space touching the end of OctoMap's key range: rock beyond it cannot be represented, so
// the outermost key layer counts as rock, and nothing wraps round to the far side of the map.
TEST(DistanceField, FreeSpaceAtTheEdgeOfTheKeyRangeMatchesBruteForce) {
  for (const int x0 : {0, 65535 - 19}) {
    auto tree = std::make_shared<octomap::OcTree>(0.1);
    for (int x = x0; x < x0 + 20; ++x)
      for (int y = 100; y < 120; ++y)
        for (int z = 100; z < 120; ++z)
          tree->setNodeValue(octomap::OcTreeKey(octomap::key_type(x), octomap::key_type(y), octomap::key_type(z)),
                             tree->getClampingThresMinLog());
    StatusOr<OccupancyMap> map = OccupancyMap::create(tree);
    ASSERT_TRUE(map.ok());
    StatusOr<DistanceField> df = DistanceField::build(*map);
    ASSERT_TRUE(df.ok()) << df.status().toString();
    StatusOr<BruteForceDistance> oracle = BruteForceDistance::create(*map);
    ASSERT_TRUE(oracle.ok());
    std::mt19937_64 rng(11);
    for (int i = 0; i < 500; ++i) {
      const Vec3 p = test::randomPoint(rng, map->bounds());
      const DistanceSample a = df->query(p), b = oracle->query(p);
      ASSERT_EQ(a.in_rock, b.in_rock) << p.transpose();
      EXPECT_NEAR(a.distance, b.distance, 0.05) << p.transpose();
    }
  }
}

TEST(DistanceField, UpdateOutsideTheTilesOrHugeIsHandled) {
  OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4, 3)));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  const double before = df->distance({5, 0, 1.5});
  // Far from any tile: all rock there, nothing to do.
  EXPECT_TRUE(df->update(map, Aabb({500, 500, 500}, {501, 501, 501})).ok());
  // A window of kilometres: falls back to a rebuild from the octree instead of scanning it.
  EXPECT_TRUE(df->update(map, Aabb(Vec3::Constant(-2000), Vec3::Constant(2000))).ok());
  EXPECT_TRUE(df->update(map, Aabb(Vec3::Constant(-1e300), Vec3::Constant(1e300))).ok());
  EXPECT_DOUBLE_EQ(df->distance({5, 0, 1.5}), before);
  EXPECT_FALSE(df->update(map, Aabb(Vec3::Constant(NAN), Vec3::Constant(1))).ok());
}

TEST(DistanceField, RockAndBadInputGiveZeroDistance) {
  const OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4, 3)));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  for (const Vec3& p : {Vec3(5, 10, 1), Vec3(5, 0, -2), Vec3(1e9, 0, 0), Vec3(NAN, 0, 0), Vec3(5, 0, INFINITY)}) {
    const DistanceSample s = df->query(p);
    EXPECT_TRUE(s.in_rock) << p.transpose();
    EXPECT_EQ(s.distance, 0.0);
    EXPECT_EQ(s.gradient, Vec3::Zero());
  }
}

TEST(DistanceField, MemoryIsProportionalToRoadwaysNotBoundingBox) {
  // Two 60 m roadways 400 m apart: the bounding box is 2400x larger than the free space.
  SurveyNetwork net;
  net.resolution_m = 0.25;
  net.stations = {{"A", {0, 0, 0}}, {"B", {60, 0, 0}}, {"C", {0, 400, 0}}, {"D", {60, 400, 0}}};
  net.sections = {{"s", CrossSection::rectangle(4, 3)}};
  net.roadways = {{"r1", {"A", "B"}, "s"}, {"r2", {"C", "D"}, "s"}};
  const OccupancyMap map = test::voxelizeOrFail(net);
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  const double box_voxels = map.bounds().volume() / std::pow(map.resolution(), 3);
  EXPECT_LT(double(df->stats().memory_bytes), 0.05 * box_voxels * 8.0);
  EXPECT_LT(df->stats().bytesPerFreeVoxel(), 64.0);
}

// Sites beyond the cells' offset range live in the far table. Clearances of 255 voxels take a
// free ball of 70 M voxels to reach, so the test lowers the range to 1 voxel: nearly every site
// goes through the table, and the answers (sites, distances, gradients; after window updates
// too) must be exactly those of the normal field, and of brute force.
TEST(DistanceField, SitesInTheFarTableAreExact) {
  OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.25));
  StatusOr<DistanceField> near = DistanceField::build(map);
  StatusOr<DistanceField> far = DistanceField::buildWithNearLimitForTesting(map, 1);
  ASSERT_TRUE(near.ok() && far.ok());
  EXPECT_EQ(near->stats().far_sites, 0u);
  EXPECT_GT(far->stats().far_sites, far->stats().free_voxels / 2);
  EXPECT_EQ(near->stats().free_voxels, far->stats().free_voxels);
  EXPECT_EQ(near->stats().max_distance_m, far->stats().max_distance_m);
  StatusOr<BruteForceDistance> oracle = BruteForceDistance::create(map);
  ASSERT_TRUE(oracle.ok());
  auto same = [&](const DistanceField& a, const DistanceField& b, int seed) {
    std::mt19937_64 rng(seed);
    const double res = map.resolution();
    for (int i = 0; i < 3000; ++i) {
      const Vec3 p = test::randomPoint(rng, map.bounds());
      const DistanceSample x = a.query(p), y = b.query(p);
      ASSERT_EQ(x.in_rock, y.in_rock) << p.transpose();
      ASSERT_EQ(x.distance, y.distance) << p.transpose();
      ASSERT_EQ(x.gradient, y.gradient) << p.transpose();
      const Vec3 c = ((p / res).array().floor() + 0.5) * res;
      if (a.isFree(c)) {
        ASSERT_EQ(a.nearestRockVoxel(c), b.nearestRockVoxel(c)) << c.transpose();
      }
    }
  };
  same(*near, *far, 5);
  std::mt19937_64 rng(6);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p = test::randomPoint(rng, map.bounds());
    const DistanceSample a = far->query(p), b = oracle->query(p);
    ASSERT_EQ(a.in_rock, b.in_rock) << p.transpose();
    EXPECT_NEAR(a.distance, b.distance, 0.5 * map.resolution()) << p.transpose();
    EXPECT_GE(a.distance + 1e-9, b.distance);
  }
  // Rubble falls, is cleared, falls again: the far entries the updates rewrite are dropped
  // once they outnumber the live ones, and the answers stay those of a fresh build.
  std::vector<Vec3> rubble;
  for (double x = 3.0; x < 4.0; x += 0.25)
    for (double y = -0.5; y < 0.5; y += 0.25)
      for (double z = 0.1; z < 1.1; z += 0.25) rubble.push_back({x, y, z});
  const Aabb window({3.0, -0.5, 0.1}, {4.0, 0.5, 1.1});
  for (int round = 0; round < 6; ++round) {
    const VoxelState s = round % 2 == 0 ? VoxelState::kOccupied : VoxelState::kFree;
    ASSERT_TRUE(map.setVoxels(rubble, s).ok());
    ASSERT_TRUE(near->update(map, window).ok());
    ASSERT_TRUE(far->update(map, window).ok());
    same(*near, *far, 10 + round);
  }
  StatusOr<DistanceField> fresh = DistanceField::build(map);
  ASSERT_TRUE(fresh.ok());
  same(*fresh, *far, 20);
  EXPECT_LE(far->stats().far_sites, 2 * far->stats().free_voxels + 4096);
}

}  // namespace
}  // namespace adit::map
