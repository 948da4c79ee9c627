// SPDX-License-Identifier: BSD-3-Clause
// The global planner on generated roadways: routing, blocking, validity, determinism, ground
// mode, and path length against the 26-connected grid optimum.
#include <gtest/gtest.h>

#include "adit/map/rock_points.hpp"

#include <chrono>
#include <cmath>
#include <cstring>
#include <random>

#include "adit/global/global_planner.hpp"
#include "adit/global/grid_reference.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::global {
namespace {

using map::CrossSection;
using map::Vec3;

// A taut any-angle path is shorter than the 45-degree zig-zag of the grid; allow a little for
// paths that must bend around several corners at the required clearance.
constexpr double kGridRatioLimit = 1.02;

struct World {
  map::SurveyNetwork net;
  map::OccupancyMap map;
  map::DistanceField field;

  explicit World(map::SurveyNetwork n)
      : net(std::move(n)), map(test::voxelizeOrFail(net)), field(std::move(map::DistanceField::build(map)).value()) {}

  // The searches here end on iteration caps, so that what a test sees does not depend on how
  // loaded the machine is: the default 2 s wall-clock budget becomes a hang guard far beyond
  // them, and a search with no solution gives up after a fixed number of iterations. (A test
  // that sets its own budget keeps it.)
  GlobalPlanner planner(GlobalPlannerParams p = {}, bool with_survey = true) const {
    if (p.time_budget_s == GlobalPlannerParams{}.time_budget_s) {
      p.time_budget_s = 120.0;
      if (p.max_unsolved_iterations == 0) p.max_unsolved_iterations = 20000;
    }
    StatusOr<GlobalPlanner> g = GlobalPlanner::create(map, field, p, with_survey ? &net : nullptr);
    EXPECT_TRUE(g.ok()) << g.status().toString();
    return std::move(g).value();
  }
  // Rock over a box (a roof fall), with the field and the planner's graph brought up to date.
  void fall(const map::Aabb& box, GlobalPlanner* planner) {
    ASSERT_TRUE(map.setVoxels(test::pointsInBox(box, map.resolution()), map::VoxelState::kOccupied).ok());
    ASSERT_TRUE(field.update(map, box).ok());
    planner->mapChanged(box);
  }
};

GlobalPlannerParams rrtConnect() {
  GlobalPlannerParams p;
  p.planner = PlannerType::kRrtConnect;
  return p;
}

// The bundled ground rescue's tracked robot (1.0 x 0.7 x 0.6 m) on the floor.
GlobalPlannerParams trackedRobot() {
  GlobalPlannerParams p = rrtConnect();
  p.mode = PlanMode::kGround;
  p.robot = map::RobotShape::box({1.0, 0.7, 0.6});
  return p;
}

double gridLength(const World& w, const GlobalPlanner& planner, const Vec3& a, const Vec3& b) {
  StatusOr<GridPathResult> g =
      gridOptimum([&](const Vec3& c) { return planner.stateValid(c); }, w.map.resolution(), a, b);
  if (!g.ok()) {
    ADD_FAILURE() << g.status().toString();
    return std::nan("");
  }
  EXPECT_TRUE(g->found);
  return g->length_m;
}

void expectValidPath(const GlobalPlanner& planner, const GlobalPlanResult& r, const Vec3& start, const Vec3& goal) {
  ASSERT_TRUE(r.solved()) << outcomeName(r.outcome) << ": " << r.message;
  ASSERT_GE(r.path.size(), 2u);
  EXPECT_LT((r.path.points.front() - start).norm(), 1e-9);
  EXPECT_LT((r.path.points.back() - goal).norm(), 1e-9);
  EXPECT_TRUE(planner.validatePath(r.path).ok()) << planner.validatePath(r.path).message();
  EXPECT_NEAR(r.length_m, r.path.length(), 1e-9);
  EXPECT_GE(r.min_clearance_m, planner.params().safety_margin_m - 0.5 * 0.2 - 1e-9);
  EXPECT_GE(r.mean_clearance_m, r.min_clearance_m);
}

TEST(GlobalPlannerParams, ValidateNamesTheField) {
  GlobalPlannerParams p;
  p.time_budget_s = std::nan("");
  EXPECT_NE(p.validate().message().find("time_budget_s"), std::string::npos);
  p = {};
  p.motion_step_voxels = 2.0;
  EXPECT_NE(p.validate().message().find("motion_step_voxels"), std::string::npos);
  p = {};
  p.robot = map::RobotShape::sphere(-1);
  EXPECT_FALSE(p.validate().ok());
  EXPECT_TRUE(GlobalPlannerParams{}.validate().ok());
  EXPECT_FALSE(parsePlannerType("astar").ok());
  EXPECT_EQ(*parsePlannerType("BITstar"), PlannerType::kBitStar);
}

TEST(GlobalPlanner, StraightRoadwayIsOneSegment) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 20.0));
  GlobalPlanner planner = w.planner(rrtConnect());
  const Vec3 a(1, 0, 1.5), b(19, 0.5, 1.5);
  GlobalPlanResult r = planner.plan(a, b);
  expectValidPath(planner, r, a, b);
  EXPECT_EQ(r.path.size(), 2u);
  EXPECT_NEAR(r.length_m, (b - a).norm(), 1e-9);
  EXPECT_EQ(r.route, std::vector<std::string>{"road"});
}

TEST(GlobalPlanner, BendIsNoLongerThanTheGridOptimum) {
  World w(test::bentRoadway(CrossSection::trapezoid(4.0, 3.0, 3.0), 0.2));
  for (PlannerType type : {PlannerType::kRrtConnect, PlannerType::kBitStar, PlannerType::kInformedRrtStar}) {
    GlobalPlannerParams p;
    p.planner = type;
    p.max_iterations = 300;
    GlobalPlanner planner = w.planner(p);
    const Vec3 a(1.4, 0.5, 1.4), b(18.5, 10.8, 2.4);
    GlobalPlanResult r = planner.plan(a, b);
    expectValidPath(planner, r, a, b);
    EXPECT_GE(r.path.size(), 3u) << "a bend needs a break point";
    EXPECT_LE(r.length_m / gridLength(w, planner, a, b), kGridRatioLimit) << plannerTypeName(type);
  }
}

TEST(GlobalPlanner, JunctionAndDeadEnds) {
  World w(test::junctionNetwork(0.2));
  GlobalPlanner planner = w.planner(rrtConnect());
  // From the branch's dead end (C) to the cross-cut's dead end (E): main, branch and cross-cut.
  const Vec3 c(14, 9.0, 2.0), e(6, -7.0, 1.5);
  GlobalPlanResult r = planner.plan(c, e);
  expectValidPath(planner, r, c, e);
  EXPECT_EQ(r.route, (std::vector<std::string>{"branch", "main", "crosscut"}));
  EXPECT_LE(r.length_m / gridLength(w, planner, c, e), kGridRatioLimit);
  // Into the main's dead end at A.
  const Vec3 a(0.8, 0, 1.5);
  GlobalPlanResult r2 = planner.plan(e, a);
  expectValidPath(planner, r2, e, a);
  EXPECT_EQ(r2.route, (std::vector<std::string>{"crosscut", "main"}));
}

TEST(GlobalPlanner, BlockedRoadwayTakesTheOtherAndAllBlockedIsNoPathAtOnce) {
  World w(test::ladderNetwork());
  GlobalPlanner planner = w.planner(rrtConnect());
  const Vec3 a(4, 0, 1.5), b(4, 16, 1.5);
  GlobalPlanResult r = planner.plan(a, b);
  expectValidPath(planner, r, a, b);
  EXPECT_EQ(r.route, (std::vector<std::string>{"south", "west", "north"}));

  // Roof fall in the west cross-cut: the planner goes round by the east one.
  w.fall({Vec3(-2.5, 7, -0.5), Vec3(2.5, 8, 3.5)}, &planner);
  GlobalPlanResult r2 = planner.plan(a, b);
  expectValidPath(planner, r2, a, b);
  EXPECT_EQ(r2.route, (std::vector<std::string>{"south", "east", "north"}));
  EXPECT_GT(r2.length_m, 55.0);

  // And in the east one: disconnected, reported without sampling.
  w.fall({Vec3(27.5, 7, -0.5), Vec3(32.5, 8, 3.5)}, &planner);
  GlobalPlanResult r3 = planner.plan(a, b);
  EXPECT_EQ(r3.outcome, GlobalPlanOutcome::kNoPath);
  EXPECT_NE(r3.message.find("disconnected"), std::string::npos) << r3.message;
  EXPECT_NE(r3.message.find("west"), std::string::npos) << r3.message;
  EXPECT_EQ(r3.iterations, 0) << "no time may be spent sampling";
  EXPECT_TRUE(r3.path.empty());
}

TEST(GlobalPlanner, StartAndGoalOnABlockedRoadwayLeaveItAwayFromTheFall) {
  World w(test::ladderNetwork());
  GlobalPlanner planner = w.planner(rrtConnect());
  // Roof fall in the middle of the south roadway; start and goal on either side of it.
  w.fall({Vec3(14.5, -2.5, -0.5), Vec3(15.5, 2.5, 3.5)}, &planner);
  const Vec3 a(4, 0, 1.5), b(26, 0, 1.5);
  GlobalPlanResult r = planner.plan(a, b);
  expectValidPath(planner, r, a, b);
  EXPECT_EQ(r.route, (std::vector<std::string>{"south", "west", "north", "east", "south"}));
  EXPECT_GT(r.length_m, 50.0);
  // On the same side of the fall: straight along the south roadway.
  GlobalPlanResult r2 = planner.plan(a, {12, 0, 1.5});
  ASSERT_TRUE(r2.solved()) << r2.message;
  EXPECT_EQ(r2.route, std::vector<std::string>{"south"});
}

TEST(GlobalPlanner, EndpointsInRockOrOutsideAreRefused) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 12.0));
  GlobalPlanner planner = w.planner(rrtConnect());
  const Vec3 ok(2, 0, 1.5);
  EXPECT_EQ(planner.plan({2, 0, -0.3}, ok).outcome, GlobalPlanOutcome::kStartInRock);
  EXPECT_EQ(planner.plan(ok, {6, 1.9, 1.5}).outcome, GlobalPlanOutcome::kGoalInRock) << "robot does not fit by the wall";
  EXPECT_EQ(planner.plan({2, 30, 1.5}, ok).outcome, GlobalPlanOutcome::kStartOutsideMap);
  EXPECT_EQ(planner.plan(ok, {std::nan(""), 0, 1}).outcome, GlobalPlanOutcome::kGoalOutsideMap);
  GlobalPlanResult r = planner.plan({2, 0, -0.3}, ok);
  EXPECT_NE(r.message.find("start"), std::string::npos);
  EXPECT_TRUE(isInvalidEndpoint(r.outcome));
}

// backOff: a pose inside the margin climbs the field to the nearest valid pose (brute force: no
// valid pose on the same line is closer); a valid pose is itself; rock, a roadway too narrow for
// the robot anywhere, and a limit shorter than the way out are refused.
TEST(GlobalPlanner, BackOffClimbsToTheNearestValidPose) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 12.0));
  GlobalPlanner planner = w.planner(rrtConnect());
  const Vec3 pressed(6, 1.45, 1.5);  // 0.55 m from the north rib: clear of rock, inside the margin
  ASSERT_FALSE(planner.stateValid(pressed));
  const std::optional<Vec3> q = planner.backOff(pressed, 1.0);
  ASSERT_TRUE(q.has_value());
  EXPECT_TRUE(planner.stateValid(*q));
  EXPECT_NEAR(q->x(), pressed.x(), 0.05);
  EXPECT_LT(q->y(), pressed.y());
  double nearest = 1e9;  // the first valid pose straight south, in 1 cm steps
  for (double d = 0.0; d <= 1.0; d += 0.01)
    if (planner.stateValid(pressed - Vec3(0, d, 0))) { nearest = d; break; }
  EXPECT_LE((*q - pressed).norm(), nearest + 0.5 * w.map.resolution() + 1e-9);
  EXPECT_EQ(planner.backOff(Vec3(6, 0, 1.5), 1.0), std::optional<Vec3>(Vec3(6, 0, 1.5)));
  EXPECT_FALSE(planner.backOff(Vec3(6, 2.5, 1.5), 1.0).has_value());  // in rock
  EXPECT_FALSE(planner.backOff(pressed, 0.05).has_value());           // the way out is longer
  EXPECT_FALSE(planner.backOff(Vec3(6, std::nan(""), 1.5), 1.0).has_value());
  World narrow(test::straightRoadway(CrossSection::rectangle(1.0, 3.0), 12.0));
  GlobalPlanner np = narrow.planner(rrtConnect());
  EXPECT_FALSE(np.backOff(Vec3(6, 0.1, 1.5), 1.0).has_value());  // no pose in it fits
}

// A ground robot pressed against a rib backs off along the floor: the field read where its body's
// clearance is read (at the floor the floor is the nearest rock and its gradient points up, and
// the robot, put back on the floor after each step up, went nowhere: a ground campaign's replans
// from a tight spot were refused "does not fit").
TEST(GlobalPlanner, GroundBackOffMovesAlongTheFloor) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 12.0));
  const GlobalPlannerParams p = trackedRobot();
  GlobalPlanner planner = w.planner(p);
  const std::optional<double> floor = map::floorBelow(w.field, Vec3(6, 0, 1.5), 3.0);
  ASSERT_TRUE(floor);
  const Vec3 pressed(6, 1.2, *floor + 0.3);  // 0.19 m from the north rib with its covering circle
  ASSERT_FALSE(planner.stateValid(pressed));
  const std::optional<Vec3> q = planner.backOff(pressed, 1.0);
  ASSERT_TRUE(q.has_value());
  EXPECT_TRUE(planner.stateValid(*q));
  EXPECT_NEAR(q->z(), pressed.z(), 1e-9) << "on the same floor";
  EXPECT_LT(q->y(), pressed.y());
  EXPECT_NEAR(q->x(), pressed.x(), 0.05);
}

TEST(GlobalPlanner, RevalidationCatchesACorruptedPath) {
  World w(test::bentRoadway(CrossSection::rectangle(4.0, 3.0), 0.2));
  GlobalPlanner planner = w.planner(rrtConnect());
  const Vec3 a(1.4, 0.5, 1.5), b(18.5, 10.8, 2.5);
  GlobalPlanResult r = planner.plan(a, b);
  expectValidPath(planner, r, a, b);
  map::Polyline corrupted = r.path;
  corrupted.points.erase(corrupted.points.begin() + 1, corrupted.points.end() - 1);  // cut the corner
  Status s = planner.validatePath(corrupted);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("segment 0"), std::string::npos) << s.message();
  corrupted = r.path;
  corrupted.points[1].z() -= 5.0;  // a break point pushed into the floor
  EXPECT_FALSE(planner.validatePath(corrupted).ok());
}

// A 16 m roadway closed at x = 8 by a wall one voxel thick across its whole section.
void closeWithOneVoxelWall(World& w) {
  const double r = w.map.resolution();
  std::vector<Vec3> wall;
  for (double y = -2.5; y <= 2.5; y += r)
    for (double z = -0.5; z <= 3.5; z += r) wall.emplace_back(8.0 + 0.5 * r, y, z);
  ASSERT_TRUE(w.map.setVoxels(wall, map::VoxelState::kOccupied).ok());
  ASSERT_TRUE(w.field.update(w.map, {Vec3(7.5, -3, -1), Vec3(8.5, 3, 4)}).ok());
}

TEST(GlobalPlanner, OneVoxelWallIsNeverJumped) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 16.0));
  closeWithOneVoxelWall(w);
  if (HasFatalFailure()) return;
  const Vec3 a(2, 0, 1.5), b(14, 0, 1.5);
  // Plain OMPL in the whole box: nothing to route, only the motion checks stand in the way.
  GlobalPlannerParams p = rrtConnect();
  p.use_roadway_graph = false;
  p.time_budget_s = 0.3;
  GlobalPlanner planner = w.planner(p, false);
  map::Polyline straight;
  straight.points = {a, b};
  EXPECT_FALSE(planner.validatePath(straight).ok());
  GlobalPlanResult res = planner.plan(a, b);
  EXPECT_FALSE(res.solved()) << res.message;
  // The roadway graph sees the wall as a blocked roadway.
  GlobalPlanner routed = w.planner(rrtConnect());
  EXPECT_EQ(routed.plan(a, b).outcome, GlobalPlanOutcome::kNoPath);
}

// An unsolvable search ends on the iteration cap, not on the clock: the same way on any machine
// under any load (what makes a batch's table independent of its worker count).
TEST(GlobalPlanner, UnsolvedSearchStopsOnTheIterationCap) {
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 16.0));
  closeWithOneVoxelWall(w);
  if (HasFatalFailure()) return;
  for (PlannerType type : {PlannerType::kRrtConnect, PlannerType::kBitStar}) {
    GlobalPlannerParams p;
    p.planner = type;
    p.use_roadway_graph = false;
    p.time_budget_s = 60.0;
    p.max_unsolved_iterations = 3000;
    const GlobalPlanResult res = w.planner(p, false).plan({2, 0, 1.5}, {14, 0, 1.5});
    EXPECT_FALSE(res.solved()) << res.message;
    EXPECT_FALSE(res.time_limited) << plannerTypeName(type);
    EXPECT_EQ(res.iterations, 3000) << plannerTypeName(type);
    EXPECT_NE(res.message.find("3000 iterations"), std::string::npos) << res.message;
  }
  GlobalPlannerParams bad;
  bad.max_unsolved_iterations = -1;
  EXPECT_NE(bad.validate().message().find("max_unsolved_iterations"), std::string::npos);
}

TEST(GlobalPlanner, SameSeedSamePathByteForByte) {
  World w(test::junctionNetwork(0.2));
  for (PlannerType type : {PlannerType::kRrtConnect, PlannerType::kRrtStar, PlannerType::kBitStar}) {
    GlobalPlannerParams p;
    p.planner = type;
    p.max_iterations = 200;
    p.seed = 42;
    const Vec3 c(14, 9.0, 2.0), e(6, -7.0, 1.5);
    GlobalPlanResult r1 = w.planner(p).plan(c, e);
    GlobalPlanResult r2 = w.planner(p).plan(c, e);
    ASSERT_TRUE(r1.solved() && r2.solved()) << r1.message << " / " << r2.message;
    ASSERT_FALSE(r1.time_limited);
    ASSERT_EQ(r1.path.size(), r2.path.size()) << plannerTypeName(type);
    EXPECT_EQ(0, std::memcmp(r1.path.points.data(), r2.path.points.data(), r1.path.size() * sizeof(Vec3)))
        << plannerTypeName(type);
  }
}

TEST(GlobalPlanner, GroundModeStaysOnTheFloor) {
  World w(test::bentRoadway(CrossSection::rectangle(4.0, 3.0), 0.2));
  const GlobalPlannerParams p = trackedRobot();
  GlobalPlanner planner = w.planner(p);
  GlobalPlanResult r = planner.plan({1.4, 0.5, 1.0}, {18.5, 10.8, 2.0});
  ASSERT_TRUE(r.solved()) << r.message;
  EXPECT_TRUE(planner.validatePath(r.path).ok());
  // Every point along the path: the centre 0.3 m (half the box's height) above the floor.
  const double res = w.map.resolution();
  for (std::size_t i = 0; i + 1 < r.path.size(); ++i)
    for (double t = 0; t <= 1.0; t += 0.05) {
      const Vec3 c = r.path.points[i] + t * (r.path.points[i + 1] - r.path.points[i]);
      double z = c.z();
      while (w.map.isFree({c.x(), c.y(), z})) z -= 0.5 * res;
      const double floor = (std::floor(z / res) + 1) * res;
      EXPECT_NEAR(c.z() - floor, 0.3, p.ground_tolerance_m + 1e-9) << "at " << c.transpose();
    }
}

TEST(GlobalPlanner, GroundModeRefusesATooSteepRamp) {
  // 10 m rising 5 m: 26.6 degrees.
  World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 10.0, 0.2, 5.0));
  GlobalPlannerParams p = rrtConnect();
  p.mode = PlanMode::kGround;
  const Vec3 a(1.5, 0, 2.25), b(8.5, 0, 5.75);
  GlobalPlanResult ground = w.planner(p).plan(a, b);
  EXPECT_EQ(ground.outcome, GlobalPlanOutcome::kNoPath) << ground.message;
  EXPECT_NE(ground.message.find("steep"), std::string::npos) << ground.message;
  // Without the graph the motion validator's slope limit refuses it too.
  p.use_roadway_graph = false;
  p.time_budget_s = 0.3;
  EXPECT_FALSE(w.planner(p, false).plan(a, b).solved());
  // A flier does not care; nor does a ground robot allowed 30 degrees.
  EXPECT_TRUE(w.planner(rrtConnect()).plan(a, b).solved());
  GlobalPlannerParams steep = rrtConnect();
  steep.mode = PlanMode::kGround;
  steep.max_slope_deg = 30;
  GlobalPlanResult r = w.planner(steep).plan(a, b);
  EXPECT_TRUE(r.solved()) << r.message;
}

// The tracked robot's body at heading `yaw` on the floor under `c`, grown by `grow`, is in free
// voxels: its outline every 2 cm, at three heights from 5 cm above the floor to its top, read from
// the map's voxels (not the planner's checker).
bool boxFreeOnTheMap(const World& w, const Vec3& c, double yaw, double grow) {
  const double res = w.map.resolution();
  double z = c.z();
  while (w.map.isFree({c.x(), c.y(), z})) z -= 0.25 * res;
  const double floor = (std::floor(z / res) + 1) * res;
  const double hx = 0.5 + grow, hy = 0.35 + grow, cs = std::cos(yaw), sn = std::sin(yaw);
  for (const double h : {0.05, 0.3, 0.6}) {
    for (double u = -hx; u <= hx + 1e-9; u += 0.02)
      for (const double v : {-hy, hy})
        for (const Vec3& q : {Vec3(u, v, 0), Vec3(v * hx / hy, u * hy / hx, 0)})
          if (!w.map.isFree({c.x() + cs * q.x() - sn * q.y(), c.y() + sn * q.x() + cs * q.y(), floor + h})) return false;
  }
  return true;
}

// Every sample of every segment at the segment's heading, and every break point's turn (the
// shorter way, modulo half a turn), with `grow` around the box.
void expectBoxFollowsPath(const World& w, const map::Polyline& path, double grow) {
  double yaw_in = std::nan("");
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Vec3 a = path.points[i], b = path.points[i + 1];
    const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
    if (std::isfinite(yaw_in)) {
      const double d = std::remainder(yaw - yaw_in, M_PI);
      for (double t = 0; t <= 1.0; t += 0.05)
        EXPECT_TRUE(boxFreeOnTheMap(w, a, yaw_in + t * d, grow)) << "turning at " << a.transpose();
    }
    const int n = std::max(1, int(std::ceil((b - a).norm() / 0.02)));
    for (int k = 0; k <= n; ++k) {
      const Vec3 c = a + (b - a) * (double(k) / n);
      EXPECT_TRUE(boxFreeOnTheMap(w, c, yaw, grow)) << "at " << c.transpose() << " heading " << yaw;
    }
    yaw_in = yaw;
  }
}

TEST(GlobalPlanner, GroundBoxPassesAGapNarrowerThanItsTurningCircleHeadingAlongIt) {
  // 1.6 m wide: the 1.0 x 0.7 m box turning (1.22 m across) plus its 0.2 m margin each side does
  // not fit; the box heading along the roadway does, at up to about 14 degrees off its axis.
  World w(test::straightRoadway(CrossSection::rectangle(1.6, 2.5), 10.0, 0.1));
  GlobalPlannerParams p = trackedRobot();
  p.use_roadway_graph = false;  // the free-space graph needs the turning circle's clearance
  GlobalPlanner planner = w.planner(p, false);
  const std::optional<Vec3> a = planner.standAt({1.0, 0.2, 0.5}), b = planner.standAt({9.0, -0.2, 0.5});
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(planner.stateValid(*a));  // it cannot turn on the spot there
  const GlobalPlanResult r = planner.plan(*a, *b);
  ASSERT_TRUE(r.solved()) << outcomeName(r.outcome) << ": " << r.message;
  EXPECT_TRUE(r.headed);
  EXPECT_NE(r.message.find("heading"), std::string::npos) << r.message;
  EXPECT_TRUE(planner.validatePath(r.path).ok()) << planner.validatePath(r.path).message();
  EXPECT_LT(r.length_m, 1.02 * (*b - *a).norm());
  // The oracle: the box at each segment's heading, and turning at each break point, is free on
  // the map with the margin less half a voxel of quantisation around it.
  expectBoxFollowsPath(w, r.path, p.safety_margin_m - 0.5 * w.map.resolution());
  EXPECT_GE(r.min_clearance_m, p.safety_margin_m - 0.5 * w.map.resolution());

  // Each segment fits at its own heading, but the box cannot turn a right angle between them here
  // (1.77 m across at 45 degrees with its margins); driving on backwards needs no turn.
  const std::optional<Vec3> mid = planner.standAt({5.0, 0.0, 0.5}), side = planner.standAt({5.0, 0.1, 0.5}),
                            back = planner.standAt({3.0, 0.0, 0.5});
  ASSERT_TRUE(mid && side && back);
  const Status turn = planner.validatePath(map::Polyline{{*a, *mid, *side}});
  EXPECT_FALSE(turn.ok());
  EXPECT_NE(turn.message().find("cannot turn"), std::string::npos) << turn.message();
  EXPECT_TRUE(planner.validatePath(map::Polyline{{*mid, *side}}).ok());
  EXPECT_TRUE(planner.validatePath(map::Polyline{{*a, *mid, *back}}).ok()) << planner.validatePath(map::Polyline{{*a, *mid, *back}}).message();

  // Narrower than the box and its margins (0.7 + 2 x 0.2 m): refused, saying so.
  World narrow(test::straightRoadway(CrossSection::rectangle(1.0, 2.5), 10.0, 0.1));
  GlobalPlanner refused = narrow.planner(p, false);
  const std::optional<Vec3> c = refused.standAt({1.0, 0.0, 0.5}), d = refused.standAt({9.0, 0.0, 0.5});
  ASSERT_TRUE(c && d);
  const GlobalPlanResult none = refused.plan(*c, *d);
  EXPECT_EQ(none.outcome, GlobalPlanOutcome::kStartInRock) << none.message;
  EXPECT_NE(none.message.find("at any heading"), std::string::npos) << none.message;
}

TEST(GlobalPlanner, GroundBoxThatCannotTurnARightAngleCornerIsNotSentRoundIt) {
  // Two 1.3 m-wide roadways meeting at a right angle: the box fits along each (1.1 m with its
  // margins) but not turned between them (about 1.76 m across at 45 degrees). Any path the planner
  // gives must pass the oracle; the corner admits none.
  map::SurveyNetwork net;
  net.name = "narrow-L";
  net.resolution_m = 0.1;
  net.stations = {{"A", Vec3(0, 0, 0)}, {"B", Vec3(8, 0, 0)}, {"C", Vec3(8, 8, 0)}};
  net.sections = {{"s", CrossSection::rectangle(1.3, 2.5)}};
  net.roadways = {{"east", {"A", "B"}, "s"}, {"north", {"B", "C"}, "s"}};
  World w(std::move(net));
  GlobalPlannerParams p = trackedRobot();
  p.use_roadway_graph = false;
  p.max_unsolved_iterations = 4000;
  GlobalPlanner planner = w.planner(p, false);
  const std::optional<Vec3> a = planner.standAt({1.5, 0.0, 0.5}), b = planner.standAt({8.0, 6.5, 0.5});
  ASSERT_TRUE(a && b);
  const GlobalPlanResult r = planner.plan(*a, *b);
  if (r.solved()) expectBoxFollowsPath(w, r.path, p.safety_margin_m - 0.5 * w.map.resolution());
  EXPECT_FALSE(r.solved()) << r.message;
  // Straight along one arm it goes.
  const std::optional<Vec3> e = planner.standAt({6.5, 0.0, 0.5});
  ASSERT_TRUE(e);
  const GlobalPlanResult along = planner.plan(*a, *e);
  ASSERT_TRUE(along.solved()) << along.message;
  expectBoxFollowsPath(w, along.path, p.safety_margin_m - 0.5 * w.map.resolution());
}

TEST(GlobalPlanner, CapsuleAndCylinderRobots) {
  World w(test::junctionNetwork(0.2));
  const Vec3 c(14, 9.0, 2.0), e(6, -7.0, 1.5);
  for (const map::RobotShape& shape : {map::RobotShape::capsule(0.3, 0.8), map::RobotShape::cylinder(0.4, 0.6)}) {
    GlobalPlannerParams p = rrtConnect();
    p.robot = shape;
    GlobalPlanner planner = w.planner(p);
    expectValidPath(planner, planner.plan(c, e), c, e);
  }
}

TEST(GlobalPlanner, FreeSpaceGraphWithoutASurvey) {
  World w(test::junctionNetwork(0.2));
  GlobalPlanner planner = w.planner(rrtConnect(), /*with_survey=*/false);
  // An L plus a cross-cut making a T: passages between junctions and ends, not a lattice of cells.
  EXPECT_TRUE(planner.graph().fromFreeSpaceMap());
  EXPECT_GE(planner.graph().edges().size(), 3u);
  EXPECT_LE(planner.graph().edges().size(), 8u);
  const Vec3 c(14, 9.0, 2.0), e(6, -7.0, 1.5);
  GlobalPlanResult r = planner.plan(c, e);
  expectValidPath(planner, r, c, e);
  EXPECT_LE(r.length_m / gridLength(w, planner, c, e), kGridRatioLimit);
}

}  // namespace
}  // namespace adit::global

namespace adit::global {
namespace {

// Path quality on generated roadways: random start/goal pairs in every oracle roadway, the
// default planner (BIT*) within the default 2 s budget. Targets of the issue: >= 95 % valid
// paths, length / grid optimum median <= 1.00 and worst <= 1.10.
TEST(GlobalPlannerQuality, LengthAgainstGridOptimumOnGeneratedRoadways) {
  std::vector<double> ratios;
  int attempts = 0, solved = 0;
  std::mt19937_64 rng(7);
  for (test::NamedNetwork& named : test::oracleRoadways(14.0)) {
    World w(named.net);
    GlobalPlannerParams p;
    p.max_iterations = 300;
    GlobalPlanner planner = w.planner(p);
    int made = 0;
    for (int tries = 0; made < 4 && tries < 50000; ++tries) {
      // Voxel centres, which the grid optimum starts from.
      const double res = w.map.resolution();
      auto centre = [&](const Vec3& q) { return Vec3(((q / res).array().floor() + 0.5) * res); };
      const Vec3 a = centre(test::randomPoint(rng, w.map.bounds())), b = centre(test::randomPoint(rng, w.map.bounds()));
      if ((a - b).norm() < 4.0 || !planner.stateValid(a) || !planner.stateValid(b)) continue;
      ++made;
      ++attempts;
      const GlobalPlanResult r = planner.plan(a, b);
      if (!r.solved()) {
        ADD_FAILURE() << named.name << ": " << r.message;
        continue;
      }
      ++solved;
      EXPECT_TRUE(planner.validatePath(r.path).ok());
      ratios.push_back(r.length_m / gridLength(w, planner, a, b));
    }
  }
  ASSERT_GE(attempts, 12);
  EXPECT_GE(double(solved) / attempts, 0.95);
  std::sort(ratios.begin(), ratios.end());
  ASSERT_FALSE(ratios.empty());
  EXPECT_LE(ratios[ratios.size() / 2], 1.00);
  EXPECT_LE(ratios.back(), 1.10);
  std::printf("length / grid optimum over %zu paths: median %.3f, worst %.3f\n", ratios.size(), ratios[ratios.size() / 2], ratios.back());
  RecordProperty("median_ratio", std::to_string(ratios[ratios.size() / 2]));
  RecordProperty("worst_ratio", std::to_string(ratios.back()));
}

}  // namespace
}  // namespace adit::global
