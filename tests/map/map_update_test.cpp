// SPDX-License-Identifier: BSD-3-Clause
// A map update is one transaction that reports what it changed (issue 8): setVoxels() with a
// change report, and the range sensor's ray insertion that also clears what the rays passed.
// Oracle: the map's own state queried voxel by voxel, and a distance field updated over the
// reported box against one rebuilt from scratch.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <octomap/OcTree.h>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

OccupancyMap roadway() {
  return test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 20.0, 0.2));
}

// The field updated over the reported box equals a rebuild.
void expectFieldMatchesRebuild(const OccupancyMap& map, DistanceField& df, const MapChange& change) {
  ASSERT_TRUE(df.update(map, change.box).ok());
  StatusOr<DistanceField> fresh = DistanceField::build(map);
  ASSERT_TRUE(fresh.ok());
  std::mt19937_64 rng(11);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p = test::randomPoint(rng, map.bounds());
    ASSERT_EQ(df.isFree(p), fresh->isFree(p)) << p.transpose();
    ASSERT_NEAR(df.distance(p), fresh->distance(p), 1e-9) << p.transpose();
  }
}

TEST(MapUpdate, SetVoxelsReportsOnlyWhatChanged) {
  OccupancyMap map = roadway();
  const std::uint64_t occupied0 = map.stats().occupied_voxels;
  MapChange c;
  // Two new rubble voxels and one that is rock already (the floor under the roadway).
  ASSERT_TRUE(map.setVoxels({{5.1, 0.1, 1.1}, {5.3, 0.1, 1.1}, {5.1, 0.1, -0.5}}, VoxelState::kOccupied, &c).ok());
  EXPECT_EQ(c.to_occupied, 2u);
  EXPECT_EQ(c.changed(), 2u);
  EXPECT_NEAR(c.box.min.x(), 5.0, 1e-6);
  EXPECT_NEAR(c.box.max.x(), 5.4, 1e-6);
  EXPECT_NEAR(c.box.max.z(), 1.2, 1e-6);
  EXPECT_EQ(map.stats().occupied_voxels, occupied0 + 2);
  // The same again changes nothing.
  ASSERT_TRUE(map.setVoxels({{5.1, 0.1, 1.1}}, VoxelState::kOccupied, &c).ok());
  EXPECT_TRUE(c.empty());
  EXPECT_TRUE(c.box.empty());
  // A refused batch changes nothing and reports nothing.
  MapChange untouched;
  untouched.to_free = 7;
  EXPECT_FALSE(map.setVoxels({{6.1, 0.1, 1.1}, {std::nan(""), 0, 0}}, VoxelState::kOccupied, &untouched).ok());
  EXPECT_EQ(untouched.to_free, 7u);
  EXPECT_TRUE(map.isFree({6.1, 0.1, 1.1}));
}

TEST(MapUpdate, RaysMarkReturnsAndClearWhatTheyPass) {
  OccupancyMap map = roadway();
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  // Rubble the map believes in at x = 8: a 1 m block across the ray's line.
  std::vector<Vec3> rubble;
  for (double x = 8.1; x < 9.0; x += 0.2)
    for (double y = -0.5; y < 0.5; y += 0.2)
      for (double z = 0.7; z < 1.6; z += 0.2) rubble.push_back({x, y, z});
  ASSERT_TRUE(map.setVoxels(rubble, VoxelState::kOccupied).ok());
  ASSERT_TRUE(df->update(map, Aabb({8.0, -0.6, 0.6}, {9.0, 0.6, 1.7})).ok());
  ASSERT_FALSE(map.isFree({8.5, 0.1, 1.1}));

  // The sensor at x = 2 sees through where the rubble was to a return at x = 12 (new rock).
  const Vec3 origin(2.1, 0.1, 1.1), hit(12.1, 0.1, 1.1);
  StatusOr<MapChange> c = map.insertRays(origin, {hit}, 15.0);
  ASSERT_TRUE(c.ok()) << c.status().toString();
  EXPECT_EQ(c->to_occupied, 1u);
  EXPECT_EQ(c->to_free, 5u);  // the rubble voxels on the ray's line
  EXPECT_FALSE(map.isFree(hit));
  for (double x = 8.1; x < 9.0; x += 0.2) EXPECT_TRUE(map.isFree({x, 0.1, 1.1})) << x;
  EXPECT_FALSE(map.isFree({8.5, 0.3, 1.1}));  // rubble beside the ray stays
  EXPECT_TRUE(c->box.contains({8.5, 0.1, 1.1}));
  EXPECT_TRUE(c->box.contains(hit));
  expectFieldMatchesRebuild(map, *df, *c);
}

TEST(MapUpdate, ReturnsWinOverCrossingRaysAndFarReturnsOnlyClear) {
  OccupancyMap map = roadway();
  const Vec3 origin(2.1, 0.1, 1.1);
  // Ray 1 returns at x = 6; ray 2 passes through that voxel to x = 10: x = 6 stays occupied.
  // Ray 3's return lies beyond the range: free up to the range, no rock.
  StatusOr<MapChange> c = map.insertRays(origin, {{6.1, 0.1, 1.1}, {10.1, 0.1, 1.1}, {2.1, 0.1, 2.5}}, 1.0);
  ASSERT_TRUE(c.ok()) << c.status().toString();
  // Only ray 3 is inside the 1 m range... the others are rays with no return.
  EXPECT_EQ(c->to_occupied, 0u);
  c = map.insertRays(origin, {{6.1, 0.1, 1.1}, {10.1, 0.1, 1.1}}, 15.0);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(map.isFree({6.1, 0.1, 1.1}));
  EXPECT_FALSE(map.isFree({10.1, 0.1, 1.1}));
  EXPECT_EQ(c->to_occupied, 2u);
}

TEST(MapUpdate, BadScansAreRefusedAndChangeNothing) {
  OccupancyMap map = roadway();
  const MapStats before = map.stats();
  const Vec3 origin(2.1, 0.1, 1.1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(map.insertRays(origin, {{6.1, 0.1, 1.1}}, 0.0).ok());
  EXPECT_FALSE(map.insertRays(origin, {{6.1, 0.1, 1.1}}, nan).ok());
  EXPECT_FALSE(map.insertRays({nan, 0, 0}, {{6.1, 0.1, 1.1}}, 10.0).ok());
  StatusOr<MapChange> c = map.insertRays(origin, {{6.1, 0.1, 1.1}, {1e9, 0, 0}}, 1e10);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find("return 1"), std::string::npos) << c.status().message();
  EXPECT_TRUE(map.isFree({6.1, 0.1, 1.1}));  // the good first ray was not applied either
  EXPECT_EQ(map.stats().occupied_voxels, before.occupied_voxels);
  EXPECT_EQ(map.stats().free_voxels, before.free_voxels);
  // An empty scan is a valid no-op.
  StatusOr<MapChange> none = map.insertRays(origin, {}, 10.0);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(MapUpdate, LineOfSightStopsAtRockAndAgreesWithTheRays) {
  OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.2));
  const Vec3 origin(2.1, 0.1, 1.1);
  // Along the main roadway: seen. Into the rock beside it and beyond: not.
  std::vector<char> visible;
  map.lineOfSight(origin, {{9.1, 0.1, 1.1}, {9.1, 6.1, 1.1}, {std::nan(""), 0, 0}}, visible);
  ASSERT_EQ(visible.size(), 3u);
  EXPECT_EQ(visible[0], 1);
  EXPECT_EQ(visible[1], 0);
  EXPECT_EQ(visible[2], 0);
  // Whatever is visible, the rays toward it clear no rock: insertRays only frees free voxels.
  std::mt19937_64 rng(5);
  std::vector<Vec3> targets;
  for (int i = 0; i < 300; ++i) targets.push_back(test::randomPoint(rng, map.bounds()));
  map.lineOfSight(origin, targets, visible);
  std::vector<Vec3> seen;
  for (std::size_t i = 0; i < targets.size(); ++i)
    if (visible[i] && map.isFree(targets[i])) seen.push_back(targets[i]);
  ASSERT_GT(seen.size(), 10u);
  StatusOr<MapChange> c = map.insertRays(origin, seen, 1e3);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->to_free, 0u);
  EXPECT_GT(c->to_occupied, 0u);
  for (const Vec3& p : seen) EXPECT_FALSE(map.isFree(p)) << p.transpose();  // every seen target became rock
}

}  // namespace
}  // namespace adit::map

namespace adit::map {
namespace {

// deepCopy() behaves as an independent map although it clones the octree only on its first
// write: writes to the copy (voxels and rays) never reach the original, and the original's
// distance field copied alongside updates to what a rebuild of the written copy gives.
TEST(MapUpdate, DeepCopyIsIndependentOfTheOriginal) {
  const OccupancyMap original = roadway();
  const MapStats before = original.stats();
  OccupancyMap copy = original.deepCopy();
  EXPECT_EQ(copy.sharedOctree(), original.sharedOctree());  // nothing written yet: nothing cloned
  EXPECT_EQ(copy.stats().free_voxels, before.free_voxels);

  MapChange c;
  ASSERT_TRUE(copy.setVoxels({{5.1, 0.1, 1.1}}, VoxelState::kOccupied, &c).ok());
  EXPECT_NE(copy.sharedOctree(), original.sharedOctree());
  EXPECT_TRUE(copy.isRock({5.1, 0.1, 1.1}));
  EXPECT_TRUE(original.isFree({5.1, 0.1, 1.1}));
  EXPECT_EQ(original.stats().occupied_voxels, before.occupied_voxels);
  EXPECT_EQ(copy.stats().occupied_voxels, before.occupied_voxels + 1);

  // A copy whose first write is a scan.
  OccupancyMap scanned = original.deepCopy();
  StatusOr<MapChange> rays = scanned.insertRays({2.0, 0.0, 1.5}, {{8.0, 0.0, 1.5}}, 10.0);
  ASSERT_TRUE(rays.ok()) << rays.status().message();
  EXPECT_TRUE(scanned.isRock({8.0, 0.0, 1.5}));
  EXPECT_TRUE(original.isFree({8.0, 0.0, 1.5}));

  // A refused write clones nothing it would not need and changes nothing.
  OccupancyMap refused = original.deepCopy();
  EXPECT_FALSE(refused.setVoxels({{std::nan(""), 0, 0}}, VoxelState::kOccupied).ok());
  EXPECT_EQ(refused.sharedOctree(), original.sharedOctree());

  StatusOr<DistanceField> field = DistanceField::build(original);
  ASSERT_TRUE(field.ok());
  DistanceField copied_field = *field;
  expectFieldMatchesRebuild(copy, copied_field, c);
  EXPECT_GT(field->distance({5.1, 0.1, 1.1}), 0.0);  // the original's field is untouched
}

}  // namespace
}  // namespace adit::map

namespace adit::map {
namespace {

void expectSameMap(const OccupancyMap& a, const OccupancyMap& b, std::uint64_t seed) {
  ASSERT_EQ(a.stats().free_voxels, b.stats().free_voxels);
  ASSERT_EQ(a.stats().occupied_voxels, b.stats().occupied_voxels);
  ASSERT_EQ(a.stats().unknown_voxels, b.stats().unknown_voxels);
  ASSERT_TRUE(a.bounds().min.isApprox(b.bounds().min) && a.bounds().max.isApprox(b.bounds().max));
  Aabb box = b.bounds();
  box.extend(box.min - Vec3::Constant(1.0));
  box.extend(box.max + Vec3::Constant(1.0));
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 4000; ++i) {
    const Vec3 p = test::randomPoint(rng, box);
    ASSERT_EQ(a.state(p), b.state(p)) << p.transpose();
    ASSERT_EQ(a.isFree(p), b.isFree(p)) << p.transpose();
  }
}

// A deepCopy() keeps its writes as an overlay beside the shared octree, and clones it when the
// whole tree is asked for. Oracle: an independently built map written in place with the same
// writes (every state, scans, writes back to the original state), compared voxel by voxel and by
// what each write reported, before and after the clone; the original never changes.
TEST(MapUpdate, DeepCopysOverlayReadsAsTheWrittenMapDoes) {
  const OccupancyMap original = roadway();
  OccupancyMap copy = original.deepCopy();
  OccupancyMap oracle = roadway();
  const std::shared_ptr<const octomap::OcTree> shared = original.sharedOctree();
  std::mt19937_64 rng(5);
  const Aabb inside{{0.5, -2.5, -0.5}, {19.5, 2.5, 3.5}};
  auto writeBoth = [&](int round) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 40; ++i) pts.push_back(test::randomPoint(rng, inside));
    const VoxelState st = VoxelState(round % 3);
    MapChange ca, cb;
    ASSERT_TRUE(copy.setVoxels(pts, st, &ca).ok());
    ASSERT_TRUE(oracle.setVoxels(pts, st, &cb).ok());
    EXPECT_EQ(ca.to_occupied, cb.to_occupied);
    EXPECT_EQ(ca.to_free, cb.to_free);
    EXPECT_EQ(ca.to_unknown, cb.to_unknown);
    // A scan from the roadway's axis: its rays clear what they pass.
    const Vec3 origin(2.0 + 0.7 * round, 0.0, 1.5);
    std::vector<Vec3> returns;
    for (int i = 0; i < 12; ++i) returns.push_back(test::randomPoint(rng, inside));
    StatusOr<MapChange> ra = copy.insertRays(origin, returns, 6.0), rb = oracle.insertRays(origin, returns, 6.0);
    ASSERT_TRUE(ra.ok() && rb.ok());
    EXPECT_EQ(ra->to_occupied, rb->to_occupied);
    EXPECT_EQ(ra->to_free, rb->to_free);
  };
  for (int round = 0; round < 12; ++round) writeBoth(round);
  EXPECT_EQ(original.sharedOctree(), shared);
  expectSameMap(copy, oracle, 1);
  // Written back to what the original holds: the copy reads as the original there.
  const Vec3 back(9.1, 0.1, 1.1);
  ASSERT_TRUE(copy.setVoxel(back, VoxelState::kOccupied).ok());
  ASSERT_TRUE(copy.setVoxel(back, VoxelState::kFree).ok());
  EXPECT_TRUE(copy.isFree(back));
  ASSERT_TRUE(oracle.setVoxel(back, VoxelState::kFree).ok());

  // A copy of the copy starts from its overlay and is independent of it.
  OccupancyMap second = copy.deepCopy();
  expectSameMap(second, oracle, 2);
  ASSERT_TRUE(second.setVoxel({12.1, 0.1, 1.1}, VoxelState::kOccupied).ok());
  EXPECT_TRUE(second.isRock({12.1, 0.1, 1.1}));

  // The whole tree: a clone with the overlay applied, its leaves the oracle's voxels; later
  // writes go to it.
  std::uint64_t free_leaves = 0;
  copy.forEachLeaf([&](const Vec3& c, double size, VoxelState s) {
    const auto edge = std::uint64_t(std::llround(size / copy.resolution()));
    if (s == VoxelState::kFree) free_leaves += edge * edge * edge;
    EXPECT_EQ(oracle.state(c), s) << c.transpose();
  });
  EXPECT_EQ(free_leaves, oracle.stats().free_voxels);
  EXPECT_NE(copy.sharedOctree(), shared);
  for (int round = 12; round < 18; ++round) writeBoth(round);
  expectSameMap(copy, oracle, 3);
  EXPECT_EQ(copy.stats().octree_nodes, copy.octree().size());
  EXPECT_TRUE(copy.isFree({12.1, 0.1, 1.1}) == oracle.isFree({12.1, 0.1, 1.1}));

  expectSameMap(original, roadway(), 4);
  EXPECT_EQ(original.sharedOctree(), shared);
}

// An overlay that outgrows kMaxOverlayVoxels becomes the clone, and reads the same.
TEST(MapUpdate, AnOverlayPastItsBoundBecomesTheClone) {
  const OccupancyMap original = roadway();
  OccupancyMap copy = original.deepCopy();
  const double r = original.resolution();
  std::vector<Vec3> block;  // unknown voxels beside the roadway, each a change
  const int n = int(std::ceil(std::cbrt(double(OccupancyMap::kMaxOverlayVoxels)))) + 1;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) block.push_back({40.0 + (i + 0.5) * r, (j + 0.5) * r, (k + 0.5) * r});
  MapChange c;
  ASSERT_TRUE(copy.setVoxels(block, VoxelState::kOccupied, &c).ok());
  EXPECT_EQ(c.to_occupied, block.size());
  // Still the overlay: its node count is the shared tree's plus the changed voxels.
  EXPECT_EQ(copy.stats().octree_nodes, original.stats().octree_nodes + block.size());
  ASSERT_TRUE(copy.setVoxel({5.1, 0.1, 1.1}, VoxelState::kOccupied).ok());  // past the bound: cloned
  EXPECT_EQ(copy.stats().octree_nodes, copy.octree().size());
  EXPECT_NE(copy.sharedOctree(), original.sharedOctree());
  EXPECT_EQ(copy.state(block.front()), VoxelState::kOccupied);
  EXPECT_EQ(copy.state(block.back()), VoxelState::kOccupied);
  EXPECT_TRUE(copy.isRock({5.1, 0.1, 1.1}));
  EXPECT_EQ(original.state(block.front()), VoxelState::kUnknown);
  EXPECT_TRUE(original.isFree({5.1, 0.1, 1.1}));
  EXPECT_EQ(copy.stats().occupied_voxels, original.stats().occupied_voxels + block.size() + 1);
}

}  // namespace
}  // namespace adit::map
