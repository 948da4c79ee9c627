// SPDX-License-Identifier: BSD-3-Clause
// RoadwayGraph: built from surveys (junctions where a road leaves another between stations),
// routing, blocking.
#include <gtest/gtest.h>

#include <queue>
#include <set>

#include "adit/global/roadway_graph.hpp"
#include "adit/map/survey_network.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::global {
namespace {

using map::CrossSection;
using map::Vec3;

// Roadways that meet without sharing a station: `west` starts at G, which is A under another
// name; `cross` crosses `gate` with no station there; `rib` ends on the main's north rib. And two
// that do not: `miss` ends 1.5 m short of that rib (rock between), `far` touches nothing; nor
// does `gate`, ending 2 m short of `top`.
map::SurveyNetwork unsharedJunctions() {
  map::SurveyNetwork net;
  net.name = "unshared";
  net.resolution_m = 0.25;
  net.stations = {{"A", Vec3(0, 0, 0)},   {"B", Vec3(40, 0, 0)},  {"G", Vec3(0, 0, 0)},   {"W", Vec3(0, 24, 0)},
                  {"T", Vec3(40, 24, 0)}, {"S", Vec3(12, 0, 0)},  {"N", Vec3(12, 20, 0)}, {"X0", Vec3(6, 10, 0)},
                  {"X1", Vec3(18, 10, 0)}, {"R0", Vec3(28, 2.0, 0)}, {"R1", Vec3(28, 14, 0)}, {"F0", Vec3(50, 40, 0)},
                  {"F1", Vec3(60, 40, 0)}, {"M0", Vec3(34, 3.5, 0)}, {"M1", Vec3(34, 14, 0)}};
  net.sections = {{"s", CrossSection::rectangle(4.0, 3.0)}};
  net.roadways = {{"main", {"A", "S", "B"}, "s"}, {"east", {"B", "T"}, "s"},  {"top", {"W", "T"}, "s"},
                  {"west", {"G", "W"}, "s"},      {"gate", {"S", "N"}, "s"},  {"cross", {"X0", "X1"}, "s"},
                  {"rib", {"R0", "R1"}, "s"},     {"far", {"F0", "F1"}, "s"}, {"miss", {"M0", "M1"}, "s"}};
  return net;
}

// The oracle: do roadways r and q touch in free space? Voxelize the two alone and flood the free
// voxels from the middle of r's centreline (at mid-height) to the middle of q's.
bool touchInFreeSpace(const map::SurveyNetwork& net, std::size_t r, std::size_t q) {
  map::SurveyNetwork two = net;
  two.roadways = {net.roadways[r], net.roadways[q]};
  const map::OccupancyMap m = test::voxelizeOrFail(two);
  auto mid = [&](const map::SurveyRoadway& road) {
    const Vec3 a = net.stations.at(road.stations.front()), b = net.stations.at(road.stations.back());
    return Vec3(0.5 * (a + b) + Vec3(0, 0, 1.5));
  };
  const double res = two.resolution_m;
  auto key = [&](const Vec3& p) {
    return std::array<long, 3>{std::lround(std::floor(p.x() / res)), std::lround(std::floor(p.y() / res)),
                               std::lround(std::floor(p.z() / res))};
  };
  auto centre = [&](const std::array<long, 3>& k) { return Vec3((k[0] + 0.5) * res, (k[1] + 0.5) * res, (k[2] + 0.5) * res); };
  const auto from = key(mid(net.roadways[r])), to = key(mid(net.roadways[q]));
  std::set<std::array<long, 3>> seen{from};
  std::queue<std::array<long, 3>> open;
  open.push(from);
  while (!open.empty()) {
    const auto k = open.front();
    open.pop();
    if (k == to) return true;
    for (int f = 0; f < 6; ++f) {
      auto n = k;
      n[std::size_t(f / 2)] += f % 2 ? -1 : 1;
      if (seen.count(n) || !m.isFree(centre(n))) continue;
      seen.insert(n);
      open.push(n);
    }
  }
  return false;
}

// The graph's answer: a node where edges of both roadways meet.
bool touchInGraph(const RoadwayGraph& g, const std::string& r, const std::string& q) {
  std::vector<std::set<std::string>> at(g.nodes().size());
  for (const RoadwayEdge& e : g.edges()) {
    at[std::size_t(e.from)].insert(e.roadway);
    at[std::size_t(e.to)].insert(e.roadway);
  }
  for (const auto& names : at)
    if (names.count(r) && names.count(q)) return true;
  return false;
}

TEST(RoadwayGraph, SurveyGraphJoinsRoadwaysExactlyWhereTheirFreeSpaceMeets) {
  const map::SurveyNetwork net = unsharedJunctions();
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(net);
  ASSERT_TRUE(g.ok()) << g.status().toString();
  int touching = 0;
  for (std::size_t r = 0; r < net.roadways.size(); ++r)
    for (std::size_t q = r + 1; q < net.roadways.size(); ++q) {
      const bool free = touchInFreeSpace(net, r, q);
      touching += free;
      EXPECT_EQ(touchInGraph(*g, net.roadways[r].name, net.roadways[q].name), free)
          << net.roadways[r].name << " and " << net.roadways[q].name << (free ? " touch" : " do not touch");
    }
  // main-east, main-west, main-gate, main-rib, east-top, top-west, gate-cross.
  EXPECT_EQ(touching, 7);
}

TEST(RoadwayGraph, CoincidentStationsAreOneJunction) {
  // From main's start, up `west` (which starts at G = A): about 24 m, not round by east and top.
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(unsharedJunctions());
  ASSERT_TRUE(g.ok());
  StatusOr<Route> r = g->route({3, 0, 1.5}, {3, 24, 1.5});
  ASSERT_TRUE(r.ok()) << r.status().toString();
  EXPECT_LT(r->length_m, 32.0);
  EXPECT_NE(std::find(r->roadways.begin(), r->roadways.end(), "west"), r->roadways.end());
  // And the crossing joins `cross` to `gate` (no shared station): from one to the other.
  EXPECT_TRUE(g->route({7, 10, 1.5}, {12, 19, 1.5}).ok());
  EXPECT_TRUE(g->route({28, 12, 1.5}, {38, 0, 1.5}).ok()) << "rib ends on main's rib";
}

TEST(RoadwayGraph, FromSurveyJoinsStationsAndMidSegmentJunctions) {
  // The synthetic district's gate roads start on the return airway between its stations.
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(test::syntheticDistrict(1000.0, 500.0, 0.2, 250.0));
  ASSERT_TRUE(g.ok()) << g.status().toString();
  EXPECT_GT(g->totalLength(), 3000.0);
  // Gate 0 leaves the return at x = 50: from the main's west end to the gate's top end.
  StatusOr<Route> r = g->route({1, 0, 2}, {50, 499, 22});
  ASSERT_TRUE(r.ok()) << r.status().toString();
  EXPECT_EQ(r->roadways.front(), "main");
  EXPECT_EQ(r->roadways.back(), "gate-0");
  EXPECT_NEAR(r->length_m, 1 + 40 + 50 + 460, 15.0);
  EXPECT_EQ(r->axis.points.size(), r->radius_m.size() + 1);
}

TEST(RoadwayGraph, EndsAreTheDeadEnds) {
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(test::junctionNetwork(0.2));
  ASSERT_TRUE(g.ok());
  std::vector<std::string> names;
  for (int n : g->ends()) names.push_back(g->nodes()[std::size_t(n)].name);
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"A", "C", "E"}));
}

TEST(RoadwayGraph, BlockedEdgesAreAvoidedAndNamed) {
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(test::junctionNetwork(0.2));
  ASSERT_TRUE(g.ok());
  for (std::size_t e = 0; e < g->edges().size(); ++e)
    if (g->edges()[e].roadway == "crosscut") g->setBlocked(int(e), true, "roof fall");
  StatusOr<Route> r = g->route({1, 0, 1.5}, {6, -7, 1.5});
  // The goal's only roadway is blocked: it lies in no usable corridor.
  ASSERT_FALSE(r.ok());
  StatusOr<Route> r2 = g->route({1, 0, 1.5}, {14, 9, 1.5});
  EXPECT_TRUE(r2.ok());
}

TEST(RoadwayGraph, PointsOutsideEveryCorridorAreNamed) {
  StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(test::junctionNetwork(0.2));
  ASSERT_TRUE(g.ok());
  StatusOr<Route> r = g->route({100, 100, 0}, {1, 0, 1.5});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("start"), std::string::npos);
}

}  // namespace
}  // namespace adit::global
