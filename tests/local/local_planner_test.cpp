// SPDX-License-Identifier: BSD-3-Clause
// LocalPlanner::step(): limits, refusals, never NaN, honest arrival and stuck verdicts.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "adit/local/local_planner.hpp"
#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

map::Polyline line(const Vec3& a, const Vec3& b) { return map::Polyline{{a, b}}; }

LocalPlanner make(Method m, World w = {}) {
  StatusOr<LocalPlanner> p = LocalPlanner::create(LocalParams::preset(m), std::move(w));
  EXPECT_TRUE(p.ok()) << p.status().message();
  return std::move(*p);
}

TEST(LocalPlanner, NonFiniteInputIsRefusedNotPropagated) {
  LocalPlanner p = make(Method::kTian2016);
  const map::Polyline path = line(Vec3::Zero(), Vec3(10, 0, 0));
  RobotState s;
  s.position = Vec3(kNaN, 0, 0);
  StepCommand c = p.step(s, path, {}, 0.1);
  EXPECT_EQ(c.status, StepStatus::kRefused);
  EXPECT_TRUE(map::allFinite(c.velocity) && map::allFinite(c.acceleration));
  EXPECT_STRNE(c.message, "");
  s.position = Vec3::Zero();
  EXPECT_EQ(p.step(s, path, {}, kNaN).status, StepStatus::kRefused);
  EXPECT_EQ(p.step(s, path, {}, 0.0).status, StepStatus::kRefused);
  EXPECT_EQ(p.step(s, map::Polyline{}, {}, 0.1).status, StepStatus::kRefused);
  std::vector<map::MovingObstacle> bad(1);
  bad[0].velocity = Vec3(0, kNaN, 0);
  EXPECT_EQ(p.step(s, path, bad, 0.1).status, StepStatus::kRefused);
  EXPECT_EQ(p.step(s, line(Vec3::Zero(), Vec3(kNaN, 0, 0)), {}, 0.1).status, StepStatus::kRefused);
}

TEST(LocalPlanner, CommandsStayWithinLimitsAndFiniteForRandomInput) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-5, 5);
  for (Method m : {Method::kClassic, Method::kTian2016, Method::kWang2014, Method::kVff, Method::kCvff, Method::kUuv}) {
    World w;
    w.static_obstacles = {{Vec3(3, 0, 0), 0.5}, {Vec3(5, 1, 0), 0.7}};
    LocalPlanner p = make(m, w);
    const LocalParams& prm = p.params();
    for (int i = 0; i < 300; ++i) {
      RobotState s;
      s.position = Vec3(u(rng), u(rng), u(rng) * 0.2);
      const Vec3 dir = Vec3(u(rng), u(rng), 0).normalized();
      s.velocity = dir * prm.robot.v_max_mps * std::abs(u(rng)) / 5.0;
      std::vector<map::MovingObstacle> mov(3);
      for (auto& o : mov) {
        o.shape = map::RobotShape::sphere(0.3);
        o.position = Vec3(u(rng), u(rng), 0);
        o.velocity = Vec3(u(rng), u(rng), 0) * 0.2;
      }
      mov[1].shape = map::RobotShape::box(Vec3(1, 0.5, 0.5));
      mov[2].shape = map::RobotShape::cylinder(0.3, 1.0);
      const StepCommand c = p.step(s, line(Vec3::Zero(), Vec3(12, 2, 0)), mov, 0.1);
      ASSERT_NE(c.status, StepStatus::kRefused) << c.message;
      ASSERT_TRUE(map::allFinite(c.velocity) && map::allFinite(c.acceleration) && map::allFinite(c.sub_goal));
      EXPECT_LE(c.velocity.norm(), prm.robot.v_max_mps + 1e-9);
      EXPECT_LE(c.acceleration.norm(), prm.robot.a_max_mps2 + 1e-9);
    }
  }
}

TEST(LocalPlanner, ArrivedOnlyWithinTheTolerance) {
  LocalPlanner p = make(Method::kTian2016);
  const map::Polyline path = line(Vec3::Zero(), Vec3(10, 0, 0));
  RobotState s;
  s.position = Vec3(9.45, 0, 0);
  EXPECT_NE(p.step(s, path, {}, 0.1).status, StepStatus::kArrived);
  s.position = Vec3(9.55, 0, 0);
  EXPECT_EQ(p.step(s, path, {}, 0.1).status, StepStatus::kArrived);
}

TEST(LocalPlanner, SubGoalIsTheNextBreakPointAndNeverGoesBack) {
  LocalPlanner p = make(Method::kTian2016);
  const map::Polyline path{{Vec3(0, 0, 0), Vec3(4.9, 5, 0), Vec3(10.8, 6.2, 0), Vec3(14, 14, 0)}};
  RobotState s;
  s.position = Vec3(1, 1, 0);
  EXPECT_EQ(p.step(s, path, {}, 0.1).sub_goal, Vec3(4.9, 5, 0));
  s.position = Vec3(7, 5.5, 0);
  EXPECT_EQ(p.step(s, path, {}, 0.1).sub_goal, Vec3(10.8, 6.2, 0));
  s.position = Vec3(2, 2, 0);  // pushed back: the sub-goal does not regress
  EXPECT_EQ(p.step(s, path, {}, 0.1).sub_goal, Vec3(10.8, 6.2, 0));
}

// A caller's sub-goal (the fusion layer's per-period choice) replaces the break point as the
// attraction's point; the path still decides the segment and arrival. Classic: the force is
// exactly toward the attraction's point in open space, so the command's direction shows it.
TEST(LocalPlanner, CallersSubgoalIsWhatTheAttractionAimsAt) {
  for (Method m : {Method::kClassic, Method::kTian2016}) {
    LocalPlanner p = make(m);
    const map::Polyline path{{Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(10, 10, 0)}};
    RobotState s;
    s.position = Vec3(1, 0, 0);  // on the line: the line field pulls nowhere
    const Vec3 aim(2, 1, 0);
    p.setSubgoal(aim);
    StepCommand c = p.step(s, path, {}, 0.1);
    EXPECT_EQ(c.sub_goal, aim) << methodName(m);
    ASSERT_GT(c.velocity.norm(), 0.0);
    EXPECT_NEAR(c.velocity.normalized().dot((aim - s.position).normalized()), 1.0, 1e-9) << methodName(m);
    EXPECT_EQ(p.currentSegment(), 0u);
    // The segment still follows the path, not the sub-goal.
    s.position = Vec3(9.5, 0.2, 0);
    p.step(s, path, {}, 0.1);
    EXPECT_EQ(p.currentSegment(), 1u);
    // Arrival is the goal's, wherever the sub-goal is.
    s.position = Vec3(10, 9.8, 0);
    EXPECT_EQ(p.step(s, path, {}, 0.1).status, StepStatus::kArrived);
    // Cleared: back to the break point.
    p.clearSubgoal();
    s.position = Vec3(10, 5, 0);
    c = p.step(s, path, {}, 0.1);
    EXPECT_EQ(c.sub_goal, Vec3(10, 10, 0));
    EXPECT_GT(c.velocity.normalized().y(), 0.99) << methodName(m);
  }
}

TEST(LocalPlanner, NonFiniteSubgoalIsRefused) {
  LocalPlanner p = make(Method::kTian2016);
  p.setSubgoal(Vec3(kNaN, 0, 0));
  RobotState s;
  const StepCommand c = p.step(s, line(Vec3::Zero(), Vec3(10, 0, 0)), {}, 0.1);
  EXPECT_EQ(c.status, StepStatus::kRefused);
  EXPECT_TRUE(map::allFinite(c.velocity));
}

// A robot held in a local minimum (a wall of discs across the straight path, no way round for a
// classic APF) reports stuck after a bounded time, and stays stuck until the path changes.
TEST(LocalPlanner, ClassicSaysStuckAfterTheWindowAndResetsOnANewPath) {
  World w;
  for (double y = -3; y <= 3; y += 0.4) w.static_obstacles.push_back({Vec3(5, y, 0), 0.3});
  LocalPlanner p = make(Method::kClassic, w);
  const map::Polyline path = line(Vec3::Zero(), Vec3(10, 0, 0));
  RobotState s;
  int steps = 0;
  StepCommand c;
  for (; steps < 2000; ++steps) {
    c = p.step(s, path, {}, 0.1);
    if (c.status == StepStatus::kStuck) break;
    s.position += s.velocity * 0.05 + c.velocity * 0.05;
    s.velocity = c.velocity;
  }
  ASSERT_EQ(c.status, StepStatus::kStuck);
  EXPECT_LT(steps, 400);  // window 4 s after the last progress
  EXPECT_LT(s.position.x(), 5.0);
  EXPECT_EQ(p.step(s, path, {}, 0.1).status, StepStatus::kStuck);
  // A replanned path to the same goal with as many points is still a new path.
  EXPECT_NE(p.step(s, line(s.position, Vec3(10, 0, 0)), {}, 0.1).status, StepStatus::kStuck);
}

// Yielding to a closing mover pauses the monitor, but only for max_wait_s: a sensor that reports
// an obstacle closing in forever cannot keep a trapped robot from saying stuck.
TEST(LocalPlanner, WaitingForMoversIsForgivenOnlyUpToMaxWait) {
  World w;
  for (double y = -3; y <= 3; y += 0.4) w.static_obstacles.push_back({Vec3(5, y, 0), 0.3});
  LocalPlanner p = make(Method::kClassic, w);
  const map::Polyline path = line(Vec3::Zero(), Vec3(10, 0, 0));
  std::vector<map::MovingObstacle> mov(1);
  mov[0].shape = map::RobotShape::sphere(0.2);
  mov[0].position = Vec3(4.0, -1.8, 0);
  mov[0].velocity = Vec3(0, 0.06, 0);  // always reported as closing in, never arriving
  RobotState s;
  int steps = 0;
  for (; steps < 1000; ++steps) {
    const StepCommand c = p.step(s, path, mov, 0.1);
    if (c.status == StepStatus::kStuck) break;
    s.position += 0.05 * (s.velocity + c.velocity);
    s.velocity = c.velocity;
  }
  const double t = 0.1 * steps, window = p.params().monitor.window_s, wait = p.params().monitor.max_wait_s;
  EXPECT_GT(t, wait);                  // the waiting was forgiven...
  EXPECT_LT(t, window + wait + 10.0);  // ...but not for ever
}

TEST(LocalPlanner, YieldsToAnObstacleComingHeadOn) {
  LocalPlanner p = make(Method::kTian2016);
  const map::Polyline path = line(Vec3::Zero(), Vec3(20, 0, 0));
  RobotState s;
  s.position = Vec3(5, 0, 0);
  s.velocity = Vec3(0.3, 0, 0);
  std::vector<map::MovingObstacle> mov(1);
  mov[0].shape = map::RobotShape::sphere(0.3);
  mov[0].position = Vec3(6.2, 0.05, 0);
  mov[0].velocity = Vec3(-0.8, 0, 0);
  const StepCommand c = p.step(s, path, mov, 0.1);
  EXPECT_EQ(c.status, StepStatus::kYielding);
  EXPECT_LT(c.velocity.x(), s.velocity.x());
}

TEST(LocalPlanner, CreateRefusesBadParamsAndObstacles) {
  LocalParams prm = LocalParams::preset(Method::kUuv);
  prm.uuv.rho0_m = 0;
  EXPECT_FALSE(LocalPlanner::create(prm, {}).ok());
  World w;
  w.static_obstacles = {{Vec3(kNaN, 0, 0), 1}};
  EXPECT_FALSE(LocalPlanner::create(LocalParams::preset(Method::kUuv), w).ok());
  World box;
  box.shape = map::RobotShape::box(Vec3(1, 1, 1));
  EXPECT_FALSE(LocalPlanner::create(LocalParams::preset(Method::kUuv), box).ok());  // needs a checker
}

// A box-shaped robot near a roadway wall: the rock distance comes from the exact CollisionChecker
// (the box's corner is nearer the wall than its centre suggests), and the command pushes it away.
TEST(LocalPlanner, NonSphericalRobotUsesTheCollisionChecker) {
  const map::OccupancyMap m =
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 12.0));
  StatusOr<map::DistanceField> f = map::DistanceField::build(m);
  ASSERT_TRUE(f.ok());
  StatusOr<map::CollisionChecker> checker = map::CollisionChecker::create(m, *f);
  ASSERT_TRUE(checker.ok());
  World sphere_world;
  sphere_world.field = &*f;
  World box_world = sphere_world;
  box_world.checker = &*checker;
  box_world.shape = map::RobotShape::box(Vec3(1.6, 1.6, 0.6));  // half-diagonal 1.13 m
  LocalPlanner sphere = make(Method::kTian2016, sphere_world), box = make(Method::kTian2016, box_world);
  RobotState s;
  s.position = Vec3(6, 1.0, 1.5);  // 1 m from the wall at y = 2
  s.velocity = Vec3(0.3, 0, 0);
  const map::Polyline path = line(Vec3(1, 1.0, 1.5), Vec3(11, 1.0, 1.5));
  const StepCommand cs = sphere.step(s, path, {}, 0.1), cb = box.step(s, path, {}, 0.1);
  ASSERT_NE(cb.status, StepStatus::kRefused) << cb.message;
  EXPECT_NEAR(cb.clearance_m, 2.0 - 1.0 - 0.8, 0.05);  // the box's side is 0.8 m from its centre
  EXPECT_LT(cb.clearance_m, cs.clearance_m);
  EXPECT_LT(cb.velocity.y(), 0.0);  // pushed away from the wall
}

}  // namespace
}  // namespace adit::local
