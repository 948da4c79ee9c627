// SPDX-License-Identifier: BSD-3-Clause
// Planning on maps no survey describes: the real Jinchuan LiDAR scans and the Koutzi mesh of
// ../shared/data, converted as the README shows, planned end to end with the defaults (no
// planner flag, 2 s), each path checked independently of the planner and its distance field
// (every voxel of the octree that the robot's sphere touches is free). Compiled in only when the
// data is there (ADIT_HAVE_MINE_DATA).
#include <gtest/gtest.h>

#ifdef ADIT_HAVE_MINE_DATA


#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <queue>

#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/free_space.hpp"
#include "adit/map/readers/import.hpp"

namespace adit::global {
namespace {

using map::Vec3;

const std::string kData = ADIT_SHARED_DATA_DIR;
// The merged Jinchuan scan after the thin rock is cleared: measured (see docs/maps.md).
constexpr double kMinLargestShare = 0.9, kMinFarthestByRoadM = 280.0;  // measured 0.97, 311.9 m

struct RealWorld {
  map::OccupancyMap map;
  map::DistanceField field;
};

RealWorld convert(const std::string& file, double res, const Vec3& seed, std::optional<double> thin_m = {}) {
  StatusOr<map::Geometry> g = map::readGeometry(kData + "/" + file);
  EXPECT_TRUE(g.ok()) << g.status().message();
  map::ImportParams p;
  p.resolution_m = res;
  p.seed = seed;
  p.thin_radius_m = thin_m;
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
  // At 0.5 m voxels this sparse merge keeps scan noise inside the roadways; the default thin-rock
  // clearing (one voxel) leaves 23 parts of the robot's free space, the largest 353 m of 673 m
  // (--thin 1 joins it: JinchuanMergedScanIsOneNetworkWithALoop).
  const RealWorld w = convert("jinchuan_mine_pcd/21_all_25_all.pcd", 0.5, {10, 0.8, 1});
  for (double r : {0.2, 0.3}) expectFarthestEndsPlan(w, r, 60.0);
}

// The graph's connected parts: per node its part, per part the passage length.
struct Parts {
  std::vector<int> of;
  std::vector<double> length;
  int count = 0;
};

Parts partsOf(const RoadwayGraph& g, int skip_edge = -1) {
  const int n = int(g.nodes().size());
  std::vector<std::vector<int>> adj(static_cast<std::size_t>(n));
  for (std::size_t e = 0; e < g.edges().size(); ++e) {
    if (int(e) == skip_edge) continue;
    adj[std::size_t(g.edges()[e].from)].push_back(g.edges()[e].to);
    adj[std::size_t(g.edges()[e].to)].push_back(g.edges()[e].from);
  }
  Parts p;
  p.of.assign(std::size_t(n), -1);
  for (int s = 0; s < n; ++s) {
    if (p.of[std::size_t(s)] >= 0) continue;
    std::vector<int> stack{s};
    p.of[std::size_t(s)] = p.count;
    while (!stack.empty()) {
      const int u = stack.back();
      stack.pop_back();
      for (int v : adj[std::size_t(u)])
        if (p.of[std::size_t(v)] < 0) {
          p.of[std::size_t(v)] = p.count;
          stack.push_back(v);
        }
    }
    ++p.count;
  }
  p.length.assign(std::size_t(p.count), 0.0);
  for (const RoadwayEdge& e : g.edges()) p.length[std::size_t(p.of[std::size_t(e.from)])] += e.length_m;
  return p;
}

// Shortest distances by road from `from` over the edges, skipping `skip_edge`; predecessor edges.
std::vector<double> byRoad(const RoadwayGraph& g, int from, int skip_edge, std::vector<int>* via = nullptr) {
  const std::size_t n = g.nodes().size();
  std::vector<double> d(n, std::numeric_limits<double>::infinity());
  if (via) via->assign(n, -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
  d[std::size_t(from)] = 0;
  q.push({0.0, from});
  while (!q.empty()) {
    const auto [du, u] = q.top();
    q.pop();
    if (du > d[std::size_t(u)]) continue;
    for (std::size_t e = 0; e < g.edges().size(); ++e) {
      const RoadwayEdge& ed = g.edges()[e];
      if (int(e) == skip_edge || (ed.from != u && ed.to != u)) continue;
      const int v = ed.from == u ? ed.to : ed.from;
      if (du + ed.length_m < d[std::size_t(v)]) {
        d[std::size_t(v)] = du + ed.length_m;
        if (via) (*via)[std::size_t(v)] = int(e);
        q.push({d[std::size_t(v)], v});
      }
    }
  }
  return d;
}

Vec3 axisMiddle(const RoadwayEdge& e) {
  const auto& pts = e.axis.points;
  return pts[pts.size() / 2];
}

TEST(RealMapGraph, JinchuanMergedScanIsOneNetworkWithALoop) {
  // The registered merge converted as docs/maps.md shows (--thin 1: rock up to two voxels thick
  // cleared): the speckle that cut the robot's free space into 127 parts (largest 146 m of 632 m,
  // farthest ends 92 m apart by road) is gone.
  const RealWorld w = convert("jinchuan_mine_pcd/21_all_25_all.pcd", 0.5, {10, 0.8, 1}, 1.0);
  GlobalPlanner planner = plannerFor(w, 0.3);
  RoadwayGraph g = planner.graph();
  const Parts parts = partsOf(g);
  const int big = int(std::max_element(parts.length.begin(), parts.length.end()) - parts.length.begin());
  EXPECT_GT(parts.length[std::size_t(big)], kMinLargestShare * g.totalLength())
      << parts.count << " parts, largest " << parts.length[std::size_t(big)] << " m of " << g.totalLength() << " m";
  double farthest = 0;
  for (std::size_t n = 0; n < g.nodes().size(); ++n)
    if (parts.of[n] == big && g.degree(int(n)) == 1)
      for (double d : byRoad(g, int(n), -1))
        if (std::isfinite(d)) farthest = std::max(farthest, d);
  EXPECT_GT(farthest, kMinFarthestByRoadM);
  const int loops = int(g.edges().size()) - int(g.nodes().size()) + parts.count;
  EXPECT_GE(loops, 1);

  // The longest loop edge of the largest part (its ends stay joined without it) and the loop it
  // closes: the shortest way round between its ends.
  int closing = -1;
  for (std::size_t e = 0; e < g.edges().size(); ++e) {
    const RoadwayEdge& ed = g.edges()[e];
    if (parts.of[std::size_t(ed.from)] != big || ed.from == ed.to) continue;
    if (partsOf(g, int(e)).of[std::size_t(ed.to)] != partsOf(g, int(e)).of[std::size_t(ed.from)]) continue;
    if (closing < 0 || ed.length_m > g.edges()[std::size_t(closing)].length_m) closing = int(e);
  }
  ASSERT_GE(closing, 0);
  std::vector<int> via;
  byRoad(g, g.edges()[std::size_t(closing)].from, closing, &via);
  std::vector<int> cycle{closing};
  for (int n = g.edges()[std::size_t(closing)].to; n != g.edges()[std::size_t(closing)].from;) {
    const int e = via[std::size_t(n)];
    cycle.push_back(e);
    n = g.edges()[std::size_t(e)].from == n ? g.edges()[std::size_t(e)].to : g.edges()[std::size_t(e)].from;
  }
  ASSERT_GE(cycle.size(), 4u) << "a loop of " << cycle.size() << " passages";
  // Start and goal in the middle of two passages opposite on the loop; a passage between them
  // on each side is that side's branch.
  const std::size_t k = cycle.size(), half = k / 2;
  const Vec3 start = axisMiddle(g.edges()[std::size_t(cycle[0])]), goal = axisMiddle(g.edges()[std::size_t(cycle[half])]);
  // Branches: cycle[1 .. half - 1] and cycle[half + 1 .. k - 1], each not empty as k >= 4.
  const int side_a = cycle[half / 2], side_b = cycle[(half + k) / 2];

  const StatusOr<Route> open = g.route(start, goal);
  ASSERT_TRUE(open.ok()) << open.status().message();
  auto uses = [](const Route& r, int e) { return std::find(r.edges.begin(), r.edges.end(), e) != r.edges.end(); };
  ASSERT_TRUE(uses(*open, side_a) != uses(*open, side_b)) << "the open route takes one branch";
  const int taken = uses(*open, side_a) ? side_a : side_b, other = taken == side_a ? side_b : side_a;

  g.setBlocked(taken, true, "roof fall");
  const StatusOr<Route> rerouted = g.route(start, goal);
  ASSERT_TRUE(rerouted.ok()) << rerouted.status().message();
  EXPECT_FALSE(uses(*rerouted, taken));
  EXPECT_GT(rerouted->length_m, open->length_m);

  g.setBlocked(taken, false);
  const StatusOr<Route> reopened = g.route(start, goal);
  ASSERT_TRUE(reopened.ok()) << reopened.status().message();
  EXPECT_NEAR(reopened->length_m, open->length_m, 1e-9);
  EXPECT_EQ(reopened->edges, open->edges);

  g.setBlocked(taken, true, "roof fall");
  g.setBlocked(other, true, "roof fall");
  const StatusOr<Route> none = g.route(start, goal);
  ASSERT_FALSE(none.ok()) << "a route of " << none->length_m << " m with both branches blocked";
  EXPECT_EQ(none.status().code(), StatusCode::kFailedPrecondition) << none.status().message();
  std::printf("%d parts, largest %.1f of %.1f m, %d loops, farthest ends %.1f m by road; loop of %zu passages: "
              "%.1f m open, %.1f m with one branch blocked\n",
              parts.count, parts.length[std::size_t(big)], g.totalLength(), loops, farthest, cycle.size(),
              open->length_m, rerouted->length_m);
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
