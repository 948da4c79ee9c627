// SPDX-License-Identifier: BSD-3-Clause
// The free-space roadway graph (maps without a survey): its shape on generated roadways (a loop
// is a cycle, a T has one junction, a dead end is an end), exact connectivity against an
// independent grid search on pillar fields, a neck the robot just fits through, and blocking a
// branch of a loop after a roof fall.
#include <gtest/gtest.h>

#include <queue>
#include <random>
#include <set>

#include "adit/global/roadway_graph.hpp"
#include "adit/map/brute_force_distance.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::global {
namespace {

using map::CrossSection;
using map::Vec3;

struct World {
  map::OccupancyMap map;
  map::DistanceField field;
  explicit World(map::OccupancyMap m) : map(std::move(m)), field(std::move(map::DistanceField::build(map)).value()) {}
  explicit World(const map::SurveyNetwork& net) : World(test::voxelizeOrFail(net)) {}
  RoadwayGraph graph(double clearance, double slice = 1.0) const {
    StatusOr<RoadwayGraph> g = RoadwayGraph::fromFreeSpace(map, field, clearance, slice);
    EXPECT_TRUE(g.ok()) << g.status().toString();
    return std::move(g).value();
  }
  void fall(const map::Aabb& box) {
    ASSERT_TRUE(map.setVoxels(test::pointsInBox(box, map.resolution()), map::VoxelState::kOccupied).ok());
    ASSERT_TRUE(field.update(map, box).ok());
  }
};

int degree(const RoadwayGraph& g, int node) {
  int d = 0;
  for (const RoadwayEdge& e : g.edges()) d += (e.from == node) + (e.to == node);
  return d;
}
int countDegree(const RoadwayGraph& g, int want, bool at_least = false) {
  int n = 0;
  for (std::size_t i = 0; i < g.nodes().size(); ++i) {
    const int d = degree(g, int(i));
    n += at_least ? d >= want : d == want;
  }
  return n;
}
// Independent cycles: edges - nodes + connected parts.
int cycles(const RoadwayGraph& g) {
  std::vector<int> parent(g.nodes().size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = int(i);
  std::function<int(int)> find = [&](int x) { return parent[std::size_t(x)] == x ? x : parent[std::size_t(x)] = find(parent[std::size_t(x)]); };
  int parts = int(parent.size());
  for (const RoadwayEdge& e : g.edges()) {
    const int a = find(e.from), b = find(e.to);
    if (a != b) parent[std::size_t(a)] = b, --parts;
  }
  return int(g.edges().size()) - int(g.nodes().size()) + parts;
}

map::SurveyNetwork tee() {
  map::SurveyNetwork net;
  net.name = "tee";
  net.resolution_m = 0.2;
  net.stations = {{"W", Vec3(0, 0, 0)}, {"J", Vec3(20, 0, 0)}, {"E", Vec3(40, 0, 0)}, {"N", Vec3(20, 18, 0)}};
  net.sections = {{"s", CrossSection::rectangle(4.0, 3.0)}};
  net.roadways = {{"main", {"W", "J", "E"}, "s"}, {"gate", {"J", "N"}, "s"}};
  return net;
}

TEST(FreeSpaceGraph, StraightRoadwayIsOnePassageBetweenTwoEnds) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 30.0));
  const RoadwayGraph g = w.graph(0.5);
  ASSERT_EQ(g.edges().size(), 1u);
  EXPECT_EQ(g.ends().size(), 2u);
  EXPECT_EQ(g.edges()[0].roadway, "passage-1");
  // The axis runs the length of the roadway (less the robot's clearance at each face).
  EXPECT_GT(g.edges()[0].length_m, 30.0 - 2 * 0.5 - 2.0);
  EXPECT_LT(g.edges()[0].length_m, 30.0 + 0.5);
  EXPECT_TRUE(g.fromFreeSpaceMap());
  EXPECT_GT(g.freeSpaceInfo().voxels, 1000u);
}

TEST(FreeSpaceGraph, TeeHasOneJunctionOfThreePassages) {
  World w(tee());
  const RoadwayGraph g = w.graph(0.5);
  EXPECT_EQ(countDegree(g, 3, true), 1) << g.nodes().size() << " nodes";
  EXPECT_EQ(g.ends().size(), 3u);
  EXPECT_EQ(g.edges().size(), 3u);
  EXPECT_EQ(cycles(g), 0);
  // The junction is where the roadways cross, within the roadway's half-width.
  for (std::size_t i = 0; i < g.nodes().size(); ++i)
    if (degree(g, int(i)) == 3) {
      EXPECT_LT((g.nodes()[i].position.head<2>() - Vec3(20, 0, 0).head<2>()).norm(), 2.5);
    }
  // Dead ends: one near each face.
  for (const Vec3& face : {Vec3(0, 0, 0), Vec3(40, 0, 0), Vec3(20, 18, 0)}) {
    double best = 1e9;
    for (int e : g.ends()) best = std::min(best, (g.nodes()[std::size_t(e)].position.head<2>() - face.head<2>()).norm());
    EXPECT_LT(best, 2.5) << face.transpose();
  }
}

TEST(FreeSpaceGraph, LoopIsACycleAndABlockedBranchReroutes) {
  World w(test::ladderNetwork());
  RoadwayGraph g = w.graph(0.5);
  EXPECT_EQ(cycles(g), 1);
  EXPECT_GE(countDegree(g, 3, true), 2);
  const Vec3 start(4, 0, 1.5), goal(26, 0, 1.5);
  StatusOr<Route> direct = g.route(start, goal);
  ASSERT_TRUE(direct.ok()) << direct.status().toString();
  EXPECT_LT(direct->length_m, 26.0);
  // A roof fall across the south roadway: the route goes round by the north.
  w.fall({Vec3(14, -2.5, -0.5), Vec3(16, 2.5, 3.5)});
  EXPECT_EQ(g.refreshBlocked(w.field, 0.5, map::Aabb{Vec3(14, -2.5, -0.5), Vec3(16, 2.5, 3.5)}), 1);
  StatusOr<Route> around = g.route(start, goal);
  ASSERT_TRUE(around.ok()) << around.status().toString();
  EXPECT_GT(around->length_m, 2 * 16.0 + 10.0);
  bool north = false;
  for (const Vec3& p : around->axis.points) north |= p.y() > 14.0;
  EXPECT_TRUE(north);
  // And across the north one as well: no route, and the message names what is blocked.
  w.fall({Vec3(14, 13.5, -0.5), Vec3(16, 18.5, 3.5)});
  EXPECT_EQ(g.refreshBlocked(w.field, 0.5, map::Aabb{Vec3(14, 13.5, -0.5), Vec3(16, 18.5, 3.5)}), 2);
  StatusOr<Route> none = g.route(start, goal);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("blocked"), std::string::npos) << none.status().message();
  // Start and goal on either side of one fall, on the same branch: still reachable the long way
  // round? No: both branches are cut. But a goal on the start's side of the fall is.
  EXPECT_TRUE(g.route(start, Vec3(10, 0, 1.5)).ok());
}

TEST(FreeSpaceGraph, NeckTheRobotJustFitsThroughAndOneItDoesNot) {
  // A 4 m roadway narrowed to 1.2 m for 2 m in its middle.
  map::SurveyNetwork net = test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 30.0);
  World w(net);
  std::vector<Vec3> rock;
  for (double x = 14.1; x < 16.0; x += 0.2)
    for (double y = -2.1; y < 2.2; y += 0.2)
      for (double z = 0.1; z < 3.0; z += 0.2)
        if (std::abs(y) > 0.6) rock.emplace_back(x, y, z);
  ASSERT_TRUE(w.map.setVoxels(rock, map::VoxelState::kOccupied).ok());
  w.field = std::move(map::DistanceField::build(w.map)).value();
  const Vec3 a(4, 0, 1.5), b(26, 0, 1.5);
  // Clearance in the neck: 0.6 m to the ribs at its centre line.
  const RoadwayGraph fits = w.graph(0.5);
  EXPECT_TRUE(fits.route(a, b).ok());
  const RoadwayGraph does_not = w.graph(0.7);
  StatusOr<Route> r = does_not.route(a, b);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("disconnected"), std::string::npos) << r.status().message();
}

TEST(FreeSpaceGraph, RefusesAMapTooLargeForItsMemoryBudgetBeforeBuilding) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 30.0));
  FreeSpaceGraphOptions o;
  o.max_memory_bytes = 1 << 20;
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromFreeSpace(w.map, w.field, 0.5, o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.status().message().find("free-space roadway graph of this map"), std::string::npos) << g.status().message();
  EXPECT_NE(g.status().message().find("would need about"), std::string::npos) << g.status().message();
  EXPECT_NE(g.status().message().find("--resolution"), std::string::npos);
}

TEST(FreeSpaceGraph, RobotTooLargeForTheMapIsSaid) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 30.0));
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromFreeSpace(w.map, w.field, 2.5, 1.0);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.status().message().find("fits nowhere"), std::string::npos) << g.status().message();
}

// A slab of pillars (the kind of obstacle course BARN generates), 0.1 m voxels: floor and roof,
// walls, and single-voxel pillars at random with probability `fill`.
map::OccupancyMap pillarField(std::uint64_t seed, double fill, int nx = 60, int ny = 30, int nz = 5) {
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution pillar(fill);
  const double res = 0.1;
  std::vector<Vec3> free, rock;
  auto at = [&](int x, int y, int z) { return Vec3((x + 0.5) * res, (y + 0.5) * res, (z + 0.5) * res); };
  std::vector<char> column(std::size_t(nx * ny));
  for (auto& c : column) c = pillar(rng);
  for (int x = -1; x <= nx; ++x)
    for (int y = -1; y <= ny; ++y)
      for (int z = -1; z <= nz; ++z) {
        const bool inside = x >= 0 && y >= 0 && z >= 0 && x < nx && y < ny && z < nz;
        const bool is_pillar = inside && column[std::size_t(y * nx + x)];
        (inside && !is_pillar ? free : rock).push_back(at(x, y, z));
      }
  return std::move(map::OccupancyMap::fromVoxels(res, free, rock)).value();
}

// The oracle: brute-force clearance at every free voxel centre, 6-connected flood fill of those
// with clearance >= need. Returns the part number per free voxel (-1 where the robot does not fit).
std::vector<int> gridParts(const map::OccupancyMap& m, const std::vector<Vec3>& centres, double need) {
  const map::BruteForceDistance oracle = std::move(map::BruteForceDistance::create(m)).value();
  const double res = m.resolution();
  std::map<std::array<long, 3>, int> id;
  for (std::size_t i = 0; i < centres.size(); ++i)
    if (oracle.query(centres[i]).distance >= need)
      id[{std::lround(centres[i].x() / res - 0.5), std::lround(centres[i].y() / res - 0.5), std::lround(centres[i].z() / res - 0.5)}] = int(i);
  std::vector<int> part(centres.size(), -1);
  int parts = 0;
  for (const auto& [k, i] : id) {
    if (part[std::size_t(i)] >= 0) continue;
    std::queue<std::array<long, 3>> q;
    q.push(k);
    part[std::size_t(i)] = parts;
    while (!q.empty()) {
      const auto c = q.front();
      q.pop();
      for (int f = 0; f < 6; ++f) {
        auto n = c;
        n[std::size_t(f / 2)] += f % 2 ? -1 : 1;
        auto it = id.find(n);
        if (it == id.end() || part[std::size_t(it->second)] >= 0) continue;
        part[std::size_t(it->second)] = parts;
        q.push(n);
      }
    }
    ++parts;
  }
  return part;
}

TEST(FreeSpaceGraph, ConnectsExactlyWhereAGridSearchSaysTheRobotPasses) {
  // The slab's middle layer has 0.25 m of clearance, the layers beside it 0.15 m, a gap of three
  // voxels 0.15 m at its centre: all of them fit (no ties with the threshold).
  const double need = 0.145;
  int pairs = 0, agree = 0, connected = 0;
  for (double fill : {0.10, 0.20, 0.30}) {
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      World w(pillarField(seed * 7919 + std::uint64_t(fill * 100), fill));
      std::vector<Vec3> centres;
      w.map.forEachLeaf([&](const Vec3& c, double size, map::VoxelState s) {
        if (s != map::VoxelState::kFree) return;
        const int n = int(std::lround(size / 0.1));
        for (int k = 0; k < n; ++k)
          for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
              centres.push_back(c - Vec3::Constant(0.5 * size - 0.05) + 0.1 * Vec3(i, j, k));
      });
      const std::vector<int> part = gridParts(w.map, centres, need);
      StatusOr<RoadwayGraph> g = RoadwayGraph::fromFreeSpace(w.map, w.field, need, 0.5);
      ASSERT_TRUE(g.ok()) << g.status().toString();
      std::vector<std::size_t> fits;
      for (std::size_t i = 0; i < centres.size(); ++i)
        if (part[i] >= 0) fits.push_back(i);
      ASSERT_FALSE(fits.empty());
      std::mt19937_64 rng(seed);
      std::uniform_int_distribution<std::size_t> pick(0, fits.size() - 1);
      for (int k = 0; k < 40; ++k) {
        const std::size_t a = fits[pick(rng)], b = fits[pick(rng)];
        const bool oracle = part[a] == part[b];
        const bool graph = g->route(centres[a], centres[b]).ok();
        ++pairs;
        agree += oracle == graph;
        connected += oracle;
        EXPECT_EQ(graph, oracle) << "fill " << fill << " seed " << seed << ": " << centres[a].transpose() << " -> "
                                 << centres[b].transpose();
      }
    }
  }
  // Both answers occur, so the agreement means something.
  EXPECT_GT(connected, pairs / 10);
  EXPECT_LT(connected, pairs);
  EXPECT_EQ(agree, pairs);
}

TEST(FreeSpaceGraph, SameMapSameGraph) {
  World w(tee());
  const RoadwayGraph a = w.graph(0.5), b = w.graph(0.5);
  ASSERT_EQ(a.edges().size(), b.edges().size());
  for (std::size_t i = 0; i < a.edges().size(); ++i) {
    EXPECT_EQ(a.edges()[i].roadway, b.edges()[i].roadway);
    ASSERT_EQ(a.edges()[i].axis.points.size(), b.edges()[i].axis.points.size());
    for (std::size_t k = 0; k < a.edges()[i].axis.points.size(); ++k)
      EXPECT_EQ(a.edges()[i].axis.points[k], b.edges()[i].axis.points[k]);
  }
}

}  // namespace
}  // namespace adit::global
