// SPDX-License-Identifier: BSD-3-Clause
// LocalPlanner::setOverride() (issue 11): the operator's velocity set-point replaces the
// attraction, but the local layer still keeps the robot off the rock and out of the way of what
// moves.
#include <gtest/gtest.h>

#include <limits>

#include "adit/local/local_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

struct Drift {
  map::OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 20.0));
  map::DistanceField field = map::DistanceField::build(map).value();
};

LocalPlanner make(const Drift& d) {
  World w;
  w.field = &d.field;
  w.shape = map::RobotShape::sphere(0.4);
  LocalParams p = LocalParams::preset(Method::kTian2016);
  p.robot.radius_m = 0.4;
  StatusOr<LocalPlanner> lp = LocalPlanner::create(p, w);
  EXPECT_TRUE(lp.ok()) << lp.status().message();
  return std::move(*lp);
}

// Integrates the set-points as the simulator's robot would (velocity tracked within a period).
void advance(RobotState& s, const StepCommand& c, double dt) {
  s.position += 0.5 * dt * (s.velocity + c.velocity);
  s.velocity = c.velocity;
}

// Full speed at the north rib, then at the south rib diagonally, into the end wall and up at the
// roof: the robot's surface never touches rock. With the rock's repulsion the robot hovers where
// the field balances the set-point; without it (only the braking cap) it drives up to the rock.
TEST(OperatorOverride, DrivingAtARibNeverCollides) {
  const Drift d;
  const map::Polyline path{{Vec3(2, 0, 1.5), Vec3(18, 0, 1.5)}};
  const double dt = 0.1;
  for (bool repulsion : {true, false}) {
    for (const Vec3& dir : {Vec3(0, 1, 0), Vec3(0.6, -0.8, 0), Vec3(1, 0, 0), Vec3(0, 0, 1)}) {
      LocalPlanner lp = make(d);
      const double v_max = lp.params().robot.v_max_mps;
      RobotState s;
      s.position = Vec3(10, 0, 1.5);
      const double start_clearance = d.field.distance(s.position) - 0.4;
      lp.setOverride(dir * 2.0 * v_max, repulsion);  // more than the robot may: capped to v_max
      double min_clearance = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 400; ++k) {
        const StepCommand c = lp.step(s, path, {}, dt);
        ASSERT_NE(c.status, StepStatus::kRefused) << c.message;
        EXPECT_NE(c.status, StepStatus::kStuck);
        EXPECT_NE(c.status, StepStatus::kArrived);
        EXPECT_LE(c.velocity.norm(), v_max + 1e-9);
        advance(s, c, dt);
        min_clearance = std::min(min_clearance, d.field.distance(s.position) - 0.4);
      }
      EXPECT_GT(min_clearance, 0.0) << "set-point " << dir.transpose() << " repulsion " << repulsion;
      if (!repulsion) {
        EXPECT_GT((s.position - Vec3(10, 0, 1.5)).dot(dir), 0.05) << "the set-point moves the robot";
        EXPECT_LT(min_clearance, 0.25) << "up to the rock, " << dir.transpose();
      } else {
        EXPECT_LE(min_clearance, start_clearance);
      }
    }
  }
}

// A zero set-point without the rock terms is a pause: the robot stays put in open roadway...
TEST(OperatorOverride, PauseHoldsPosition) {
  const Drift d;
  LocalPlanner lp = make(d);
  const map::Polyline path{{Vec3(2, 0, 1.5), Vec3(18, 0, 1.5)}};
  lp.setOverride(Vec3::Zero(), false);
  RobotState s;
  s.position = Vec3(6, 0.5, 1.5);
  s.velocity = Vec3(0.8, 0, 0);  // moving when paused: brakes at a_max, then holds
  for (int k = 0; k < 100; ++k) advance(s, lp.step(s, path, {}, 0.1), 0.1);
  EXPECT_LT(s.velocity.norm(), 1e-6);
  const Vec3 held = s.position;
  for (int k = 0; k < 100; ++k) advance(s, lp.step(s, path, {}, 0.1), 0.1);
  EXPECT_LT((s.position - held).norm(), 1e-6);
  // ...but gives way to a vehicle coming at it.
  std::vector<map::MovingObstacle> mov(1);
  mov[0].shape = map::RobotShape::sphere(0.8);
  mov[0].position = held + Vec3(5, 0, 0);
  mov[0].velocity = Vec3(-0.6, 0, 0);
  double min_gap = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 100; ++k) {
    const StepCommand c = lp.step(s, path, mov, 0.1);
    advance(s, c, 0.1);
    mov[0].position += mov[0].velocity * 0.1;
    min_gap = std::min(min_gap, (s.position - mov[0].position).norm() - 1.2);
    EXPECT_GT(d.field.distance(s.position) - 0.4, 0.0);
  }
  EXPECT_GT((s.position - held).norm(), 0.3) << "the paused robot should back off";
}

// The override ends: the planner follows its path again, with a fresh progress monitor.
TEST(OperatorOverride, ClearOverrideReturnsToThePath) {
  const Drift d;
  LocalPlanner lp = make(d);
  const map::Polyline path{{Vec3(2, 0, 1.5), Vec3(18, 0, 1.5)}};
  RobotState s;
  s.position = Vec3(4, 0, 1.5);
  lp.setOverride(Vec3(-0.5, 0, 0), true);  // backwards, away from the goal
  for (int k = 0; k < 30; ++k) advance(s, lp.step(s, path, {}, 0.1), 0.1);
  EXPECT_LT(s.position.x(), 3.8);
  lp.clearOverride();
  EXPECT_FALSE(lp.overriding());
  // Follows again (the vertical wobble of the field in a 3 m roadway aside): real progress, and
  // no stuck verdict inherited from the time by hand.
  const double from = s.position.x();
  for (int k = 0; k < 300; ++k) {
    const StepCommand c = lp.step(s, path, {}, 0.1);
    ASSERT_NE(c.status, StepStatus::kStuck);
    advance(s, c, 0.1);
  }
  EXPECT_GT(s.position.x() - from, 8.0);
}

TEST(OperatorOverride, NonFiniteSetPointIsRefused) {
  const Drift d;
  LocalPlanner lp = make(d);
  lp.setOverride(Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0), true);
  RobotState s;
  s.position = Vec3(4, 0, 1.5);
  const StepCommand c = lp.step(s, map::Polyline{{Vec3(2, 0, 1.5), Vec3(18, 0, 1.5)}}, {}, 0.1);
  EXPECT_EQ(c.status, StepStatus::kRefused);
  EXPECT_TRUE(c.velocity.isZero());
}

}  // namespace
}  // namespace adit::local
