// SPDX-License-Identifier: BSD-3-Clause
// Planning on maps no survey describes: the real Jinchuan LiDAR scans and the Koutzi mesh of
// ../shared/data, converted as the README shows, planned end to end with the defaults (no
// planner flag, 2 s), each path checked independently of the planner and its distance field
// (every voxel of the octree that the robot's sphere touches is free). Compiled in only when the
// data is there (ADIT_HAVE_MINE_DATA).
#include <gtest/gtest.h>

#ifdef ADIT_HAVE_MINE_DATA


#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/free_space.hpp"
#include "adit/map/readers/import.hpp"

namespace adit::global {
namespace {

using map::Vec3;

const std::string kData = ADIT_SHARED_DATA_DIR;

struct RealWorld {
  map::OccupancyMap map;
  map::DistanceField field;
};

RealWorld convert(const std::string& file, double res, const Vec3& seed) {
  StatusOr<map::Geometry> g = map::readGeometry(kData + "/" + file);
  EXPECT_TRUE(g.ok()) << g.status().message();
  map::ImportParams p;
  p.resolution_m = res;
  p.seed = seed;
  StatusOr<map::ImportResult> r = map::buildMapFromGeometry(*g, p);
  EXPECT_TRUE(r.ok()) << r.status().message();
  StatusOr<map::DistanceField> f = map::DistanceField::build(r->map);
  EXPECT_TRUE(f.ok()) << f.status().message();
  return {std::move(r->map), std::move(f).value()};
}

// Independent of the distance field: every voxel whose cube comes within `radius` of a point
// sampled along the path (a quarter voxel apart) is free in the octree.
void expectSphereSweepFree(const map::OccupancyMap& m, const std::vector<Vec3>& path, double radius) {
  const double res = m.resolution();
  int bad = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const int n = std::max(1, int(std::ceil((path[i + 1] - path[i]).norm() / (0.25 * res))));
    for (int k = 0; k <= n; ++k) {
      const Vec3 c = path[i] + (path[i + 1] - path[i]) * (double(k) / n);
      const int reach = int(std::ceil(radius / res)) + 1;
      for (int z = -reach; z <= reach; ++z)
        for (int y = -reach; y <= reach; ++y)
          for (int x = -reach; x <= reach; ++x) {
            const Vec3 v = ((c / res).array().floor().matrix() + Vec3(x + 0.5, y + 0.5, z + 0.5)) * res;
            const Vec3 nearest = c.cwiseMax(v - Vec3::Constant(0.5 * res)).cwiseMin(v + Vec3::Constant(0.5 * res));
            if ((nearest - c).norm() >= radius) continue;
            if (!m.isFree(v) && ++bad <= 3) ADD_FAILURE() << "rock voxel " << v.transpose() << " within " << radius << " m of " << c.transpose();
          }
    }
  }
  EXPECT_EQ(bad, 0);
}

GlobalPlanner plannerFor(const RealWorld& w, double radius) {
  GlobalPlannerParams p;  // the defaults: BIT*, 2 s, 0.2 m margin
  p.robot = map::RobotShape::sphere(radius);
  StatusOr<GlobalPlanner> g = GlobalPlanner::create(w.map, w.field, p, nullptr);
  EXPECT_TRUE(g.ok()) << g.status().message();
  return std::move(g).value();
}

void expectFarthestEndsPlan(const RealWorld& w, double radius, double min_length_m) {
  GlobalPlanner planner = plannerFor(w, radius);
  const RoadwayGraph& g = planner.graph();
  std::optional<std::pair<int, int>> ends = g.farthestEnds();
  ASSERT_TRUE(ends);
  const Vec3 a = g.pointNearEnd(ends->first, 3.0), b = g.pointNearEnd(ends->second, 3.0);
  const GlobalPlanResult r = planner.plan(a, b);
  ASSERT_TRUE(r.solved()) << r.message;
  EXPECT_GT(r.length_m, min_length_m);
  expectSphereSweepFree(w.map, r.path.points, radius + planner.params().safety_margin_m - 0.5 * w.map.resolution());
}

TEST(RealMapGraph, JinchuanRegisteredScanPlansEndToEnd) {
  // At 0.5 m voxels this sparse merge keeps scan noise inside the roadways (single occupied
  // voxels mid-section): with the default margin the robot's free space falls into many parts,
  // the largest about 70 m of roadway long (see the free-space graph's report).
  const RealWorld w = convert("jinchuan_mine_pcd/21_all_25_all.pcd", 0.5, {10, 0.8, 1});
  for (double r : {0.2, 0.3}) expectFarthestEndsPlan(w, r, 60.0);
}

TEST(RealMapGraph, JinchuanRawScansPlanEndToEnd) {
  expectFarthestEndsPlan(convert("jinchuan_mine_pcd/2025-04-21-11-04-46.pcd", 0.3, {10, -2, 0}), 0.3, 40.0);
  expectFarthestEndsPlan(convert("jinchuan_mine_pcd/2025-05-13-10-25-38.pcd", 0.5, {10, 0.8, 1}), 0.3, 10.0);
}

TEST(RealMapGraph, KoutziMeshPlansEndToEnd) {
  const RealWorld w = convert("koutzi_mine_mesh/GM-KUM.stl", 0.2, {0, 0, 2});
  for (double r : {0.2, 0.3}) expectFarthestEndsPlan(w, r, 80.0);
}

}  // namespace
}  // namespace adit::global

#endif  // ADIT_HAVE_MINE_DATA
