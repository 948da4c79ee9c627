// SPDX-License-Identifier: BSD-3-Clause
// RoadwayGraph: built from surveys (junctions where a road leaves another between stations),
// routing, blocking.
#include <gtest/gtest.h>

#include "adit/global/roadway_graph.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::global {
namespace {

using map::Vec3;

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
