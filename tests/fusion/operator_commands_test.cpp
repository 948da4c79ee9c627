// SPDX-License-Identifier: BSD-3-Clause
// The navigator's operator commands (issue 11, console/doc/protocol.md): pause/resume, a new goal,
// blocking and reopening a survey roadway, manual control and its release. The map is a loop of
// four roadways, so a blocked one has a way round.
#include <gtest/gtest.h>

#include <limits>

#include "adit/fusion/navigator.hpp"
#include "adit/map/occupancy_map.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::fusion {
namespace {

constexpr double kRadius = 0.4, kDt = 0.1;
const Vec3 kStart(3, 0, 1.6), kGoal(21, 0, 1.6);

map::SurveyNetwork loop() {
  map::SurveyNetwork net;
  net.name = "loop";
  net.stations = {{"A", Vec3(0, 0, 0)}, {"B", Vec3(24, 0, 0)}, {"C", Vec3(24, 16, 0)}, {"D", Vec3(0, 16, 0)}};
  net.sections = {{"drift", map::CrossSection::rectangle(4.0, 3.2)}};
  net.roadways = {{"south", {"A", "B"}, "drift"}, {"east", {"B", "C"}, "drift"},
                  {"north", {"C", "D"}, "drift"}, {"west", {"D", "A"}, "drift"}};
  return net;
}

Navigator makeNavigator() {
  map::SurveyNetwork net = loop();
  map::OccupancyMap m = test::voxelizeOrFail(net);
  NavigatorParams p;
  p.local.robot.radius_m = kRadius;
  StatusOr<Navigator> nav = Navigator::create(map::LoadedMap{std::move(m), std::move(net)}, p, kGoal);
  EXPECT_TRUE(nav.ok()) << nav.status().message();
  Status s = nav->plan(kStart);
  EXPECT_TRUE(s.ok()) << s.message();
  return std::move(nav).value();
}

// The robot follows the set-points exactly (velocity tracked within the period).
struct Robot {
  local::RobotState state;
  double t = 0.0;
  explicit Robot(const Vec3& p) { state.position = p; }
  NavigatorCycle step(Navigator& nav) {
    const NavigatorCycle c = nav.cycle(t, state, {}, {}, kDt);
    state.position += 0.5 * kDt * (state.velocity + c.command.velocity);
    state.velocity = c.command.velocity;
    t += kDt;
    return c;
  }
};

double clearance(const Navigator& nav, const Vec3& p) {
  double d = 0.0;
  nav.read([&](const map::OccupancyMap&, const map::DistanceField& f) { d = f.distance(p); });
  return d - kRadius;
}

bool passesNear(const map::Polyline& path, const Vec3& p, double within) {
  return (path.nearestPoint(p) - p).norm() < within;
}

TEST(OperatorCommands, PauseHoldsPositionResumeDrivesOn) {
  Navigator nav = makeNavigator();
  Robot r(kStart);
  for (int k = 0; k < 20; ++k) EXPECT_EQ(r.step(nav).status, NavigatorStatus::kDriving);
  const double moved = (r.state.position - kStart).norm();
  EXPECT_GT(moved, 0.1);
  nav.pause();
  EXPECT_TRUE(nav.paused());
  NavigatorCycle c;
  for (int k = 0; k < 40; ++k) c = r.step(nav);
  EXPECT_EQ(c.status, NavigatorStatus::kPaused);
  EXPECT_STREQ(consoleStatusName(c), "paused");
  EXPECT_LT(c.command.velocity.norm(), 1e-9);
  const Vec3 held = r.state.position;
  for (int k = 0; k < 50; ++k) c = r.step(nav);
  EXPECT_LT((r.state.position - held).norm(), 1e-6);
  nav.resume();
  for (int k = 0; k < 20; ++k) c = r.step(nav);
  EXPECT_EQ(c.status, NavigatorStatus::kDriving);
  EXPECT_STREQ(consoleStatusName(c), "following");
  EXPECT_GT((r.state.position - held).norm(), 0.1);
}

TEST(OperatorCommands, SetGoalRefusesRockOffMapAndTightClearanceThenReplans) {
  Navigator nav = makeNavigator();
  Robot r(kStart);
  for (int k = 0; k < 5; ++k) r.step(nav);
  const map::Polyline before = nav.expectedPath();
  struct Bad { Vec3 goal; const char* says; };
  for (const Bad& b : {Bad{Vec3(12, 8, 1.6), "in rock"}, Bad{Vec3(500, 0, 1.6), "off the map"},
                       Bad{Vec3(12, 1.8, 1.6), "clearance"},
                       Bad{Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0), "not finite"}}) {
    const Status s = nav.setGoal(b.goal);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << b.says;
    EXPECT_NE(s.message().find(b.says), std::string::npos) << s.message();
  }
  EXPECT_EQ(nav.expectedPath().points, before.points) << "a refused goal changes nothing";
  EXPECT_EQ(nav.goal(), kGoal);

  const Vec3 goal(0, 12, 1.6);  // up the west roadway
  const Status s = nav.setGoal(goal);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(nav.goal(), goal);
  EXPECT_EQ(nav.expectedPath().points.back(), goal);
  EXPECT_EQ(nav.events().back().type, "replan");
  NavigatorCycle c = r.step(nav);
  EXPECT_STREQ(consoleStatusName(c), "replanning");
  c = r.step(nav);
  EXPECT_STRNE(consoleStatusName(c), "replanning");  // following, or detouring while it turns
  for (int k = 0; k < 800 && c.status == NavigatorStatus::kDriving; ++k) c = r.step(nav);
  EXPECT_EQ(c.status, NavigatorStatus::kArrived);
  EXPECT_LT((r.state.position - goal).norm(), 0.5);
}

TEST(OperatorCommands, BlockReplansRoundTheLoopAndReopenRestoresExactlyTheVoxels) {
  Navigator nav = makeNavigator();
  Robot r(kStart);
  r.step(nav);
  const Vec3 mid(12, 0, 1.6);
  ASSERT_TRUE(passesNear(nav.expectedPath(), mid, 0.5));
  // Every voxel state around the middle cross-section, to compare after the reopen.
  std::vector<std::pair<Vec3, map::VoxelState>> before;
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField&) {
    for (double x = 11.1; x < 13.0; x += 0.2)
      for (double y = -2.9; y < 3.0; y += 0.2)
        for (double z = -0.9; z < 4.2; z += 0.2) before.push_back({Vec3(x, y, z), m.state(Vec3(x, y, z))});
  });

  const StatusOr<RoadwayBlockResult> unknown = nav.blockRoadway("crosscut-90");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().code(), StatusCode::kNotFound);
  EXPECT_NE(unknown.status().message().find("known: south, east, north, west"), std::string::npos)
      << unknown.status().message();

  const StatusOr<RoadwayBlockResult> b = nav.blockRoadway("south");
  ASSERT_TRUE(b.ok()) << b.status().message();
  // A slab of 2 voxels over the whole 4 x 3.2 m section: at least 2 x 20 x 16 free voxels.
  EXPECT_GE(b->voxels, 2u * 20 * 16);
  EXPECT_TRUE(b->replanned);
  EXPECT_FALSE(b->no_route);
  EXPECT_EQ(nav.blockedRoadways(), std::vector<std::string>{"south"});
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
    EXPECT_FALSE(m.isFree(mid));
    EXPECT_EQ(f.distance(mid), 0.0);
  });
  const map::Polyline detour = nav.expectedPath();
  EXPECT_FALSE(passesNear(detour, mid, 3.0)) << "the new path must not cross the block";
  EXPECT_TRUE(passesNear(detour, Vec3(12, 16, 1.6), 1.0)) << "round the loop by the north roadway";
  EXPECT_FALSE(nav.blockRoadway("south").ok()) << "blocking twice";
  NavigatorCycle c = r.step(nav);
  EXPECT_STREQ(consoleStatusName(c), "replanning");
  EXPECT_TRUE(c.operator_replanned);

  const StatusOr<RoadwayBlockResult> o = nav.reopenRoadway("south");
  ASSERT_TRUE(o.ok()) << o.status().message();
  EXPECT_EQ(o->voxels, b->voxels);
  EXPECT_TRUE(o->replanned);
  EXPECT_TRUE(nav.blockedRoadways().empty());
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField&) {
    for (const auto& [p, state] : before) ASSERT_EQ(m.state(p), state) << p.transpose();
  });
  EXPECT_TRUE(passesNear(nav.expectedPath(), mid, 0.5)) << "the short way is open again";
  EXPECT_FALSE(nav.reopenRoadway("south").ok()) << "reopening what is not blocked";
}

TEST(OperatorCommands, BlockingTheOnlyWayLeavesNoRouteUntilReopened) {
  Navigator nav = makeNavigator();
  Robot r(kStart);
  r.step(nav);
  ASSERT_TRUE(nav.blockRoadway("south").ok());
  const StatusOr<RoadwayBlockResult> b = nav.blockRoadway("north");
  ASSERT_TRUE(b.ok()) << b.status().message();
  // The detour used north: with both blocked the robot at the start has no way to the goal.
  EXPECT_TRUE(b->no_route) << "expected no route";
  EXPECT_EQ(r.step(nav).status, NavigatorStatus::kNoRoute);
  const StatusOr<RoadwayBlockResult> o = nav.reopenRoadway("south");
  ASSERT_TRUE(o.ok());
  EXPECT_FALSE(o->no_route) << o->message;
  const NavigatorCycle c = r.step(nav);
  EXPECT_EQ(c.status, NavigatorStatus::kDriving);
  EXPECT_STREQ(consoleStatusName(c), "replanning");
}

TEST(OperatorCommands, ManualDriveAtARibKeepsClearThenReleaseFollowsAgain) {
  Navigator nav = makeNavigator();
  Robot r(Vec3(8, 0, 1.6));
  r.step(nav);
  ASSERT_FALSE(nav.release().ok()) << "release without manual control";
  ASSERT_FALSE(nav.manual(Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0)).ok());
  ASSERT_TRUE(nav.manual(Vec3(0.2, 2.0, 0)).ok());  // into the north rib, faster than allowed
  EXPECT_TRUE(nav.manualControl());
  double min_clearance = std::numeric_limits<double>::infinity();
  NavigatorCycle c;
  for (int k = 0; k < 150; ++k) {
    c = r.step(nav);
    EXPECT_EQ(c.status, NavigatorStatus::kManual);
    min_clearance = std::min(min_clearance, clearance(nav, r.state.position));
  }
  EXPECT_STREQ(consoleStatusName(c), "manual");
  EXPECT_GT(min_clearance, 0.0);
  EXPECT_GT(r.state.position.y(), 0.3) << "the set-point moved the robot toward the rib";
  const double x_before = r.state.position.x();
  ASSERT_TRUE(nav.manual(Vec3(-0.8, 0, 0)).ok());  // a new set-point replaces the old: back west
  for (int k = 0; k < 40; ++k) c = r.step(nav);
  EXPECT_LT(r.state.position.x(), x_before - 0.5);
  const Status s = nav.release();
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_FALSE(nav.manualControl());
  EXPECT_LT((nav.expectedPath().points.front() - r.state.position).norm(), 0.5) << "replanned from where it is";
  c = r.step(nav);
  EXPECT_STREQ(consoleStatusName(c), "replanning");
  const double from = (r.state.position - kGoal).norm();
  for (int k = 0; k < 300 && c.status != NavigatorStatus::kArrived; ++k) {
    c = r.step(nav);
    ASSERT_TRUE(c.status == NavigatorStatus::kDriving || c.status == NavigatorStatus::kArrived) << navigatorStatusName(c.status);
  }
  EXPECT_LT((r.state.position - kGoal).norm(), from - 5.0) << "following the new path to the goal";
}

}  // namespace
}  // namespace adit::fusion

namespace adit::fusion {
namespace {

// The same loop as an octree without its survey: the operator blocks a passage of the free-space
// roadway graph by the name `adit map graph` shows, the robot goes round the loop, and the
// reopen puts every voxel back.
TEST(OperatorCommands, OnAMapWithoutASurveyAPassageOfTheFreeSpaceGraphIsBlockedAndReopened) {
  auto make = [](const Vec3& goal) {
    map::SurveyNetwork net = loop();
    NavigatorParams p;
    p.local.robot.radius_m = kRadius;
    return Navigator::create(map::LoadedMap{test::voxelizeOrFail(net), std::nullopt}, p, goal);
  };
  StatusOr<Navigator> first = make(kGoal);
  ASSERT_TRUE(first.ok()) << first.status().message();
  // The loop is two passages meeting at two nodes (and perhaps a short stub in a corner); take
  // the longest, and start and goal on it a fifth of its length in from each end, so that its
  // middle lies between them.
  const global::RoadwayGraph& g = first->globalPlanner().graph();
  ASSERT_GE(g.edges().size(), 2u);
  std::size_t longest = 0;
  for (std::size_t k = 0; k < g.edges().size(); ++k)
    if (g.edges()[k].length_m > g.edges()[longest].length_m) longest = k;
  const global::RoadwayEdge& e = g.edges()[longest];
  ASSERT_GT(e.length_m, 25.0);
  auto along = [&](double f) {
    double left = f * e.length_m;
    for (std::size_t i = 0; i + 1 < e.axis.points.size(); ++i) {
      const double len = (e.axis.points[i + 1] - e.axis.points[i]).norm();
      if (len >= left) return Vec3(e.axis.points[i] + (e.axis.points[i + 1] - e.axis.points[i]) * (left / len));
      left -= len;
    }
    return e.axis.points.back();
  };
  const Vec3 start = along(0.2), goal = along(0.8), middle = along(0.5);
  const std::string name = e.roadway;
  StatusOr<Navigator> made = make(goal);
  ASSERT_TRUE(made.ok()) << made.status().message();
  Navigator nav = std::move(made).value();
  ASSERT_TRUE(nav.plan(start).ok());
  ASSERT_TRUE(passesNear(nav.expectedPath(), middle, 1.5));
  const double direct = nav.expectedPath().length();

  const StatusOr<RoadwayBlockResult> unknown = nav.blockRoadway("south");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().message().find("passage-1 to passage-"), std::string::npos) << unknown.status().message();
  const StatusOr<RoadwayBlockResult> b = nav.blockRoadway(name);
  ASSERT_TRUE(b.ok()) << b.status().message();
  EXPECT_GT(b->voxels, 100u);
  EXPECT_TRUE(b->replanned);
  EXPECT_FALSE(b->no_route) << b->message;
  EXPECT_FALSE(passesNear(nav.expectedPath(), middle, 1.0)) << "the new path must not cross the block";
  EXPECT_GT(nav.expectedPath().length(), direct + 10.0) << "round the loop by the other passage";
  const StatusOr<RoadwayBlockResult> o = nav.reopenRoadway(name);
  ASSERT_TRUE(o.ok()) << o.status().message();
  EXPECT_EQ(o->voxels, b->voxels);
  EXPECT_LT(nav.expectedPath().length(), direct + 1.0) << "the short way is open again";
}

}  // namespace
}  // namespace adit::fusion
