// SPDX-License-Identifier: BSD-3-Clause
// Sub-goal selection: straight on the line when far from obstacles, the annulus' minimum of U
// (lower than the straight choice) near one.
#include "adit/fusion/subgoal_selector.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace adit::fusion {
namespace {

using local::LocalParams;
using local::Method;
using local::StaticSphere;
using map::Vec3;

SubgoalQuery towardGoal(const std::vector<StaticSphere>* spheres) {
  SubgoalQuery q;
  q.position = Vec3(0, 0, 0);
  q.target = Vec3(14, 14, 0);
  q.line_a = q.position;
  q.line_b = q.target;
  q.static_obstacles = spheres;
  return q;
}

TEST(SubgoalSelector, FarFromObstaclesIsOnTheLineAtTheOuterRadius) {
  const std::vector<StaticSphere> far = {{Vec3(10, 0, 0), 0.4}};
  const LocalParams lp = LocalParams::preset(Method::kTian2016);
  const SubgoalChoice c = selectSubgoal(towardGoal(&far), lp, SubgoalParams{});
  ASSERT_EQ(c.outcome, SubgoalOutcome::kStraight) << c.message;
  EXPECT_DOUBLE_EQ(c.r_outer_m, lp.robot.v_max_mps * 1.0);
  EXPECT_DOUBLE_EQ(c.r_inner_m, 0.6 * c.r_outer_m);
  const Vec3 expected = Vec3(1, 1, 0).normalized() * c.r_outer_m;
  EXPECT_NEAR((c.subgoal - expected).norm(), 0.0, 1e-12);
  EXPECT_EQ(c.optimization.iterations, 0) << "no optimisation far from obstacles";
}

TEST(SubgoalSelector, NearAnObstacleLiesInTheAnnulusWithLowerPotential) {
  // A sphere right on the line, its surface 1.2 m ahead: the straight choice is deep in its field.
  const std::vector<StaticSphere> ahead = {{Vec3(1, 1, 0).normalized() * 1.6, 0.4}};
  for (Method m : {Method::kTian2016, Method::kClassic, Method::kUuv}) {
    LocalParams lp = LocalParams::preset(m);
    lp.robot.radius_m = 0.1;
    const SubgoalChoice c = selectSubgoal(towardGoal(&ahead), lp, SubgoalParams{});
    ASSERT_EQ(c.outcome, SubgoalOutcome::kOptimized) << local::methodName(m) << ": " << c.message;
    const double r = c.subgoal.norm();
    EXPECT_GE(r, c.r_inner_m - 1e-9);
    EXPECT_LE(r, c.r_outer_m + 1e-9);
    EXPECT_EQ(c.subgoal.z(), 0.0);
    EXPECT_LT(c.potential, c.straight_potential) << local::methodName(m);
    EXPECT_DOUBLE_EQ(c.potential, subgoalPotential(c.subgoal, towardGoal(&ahead), lp));
    // It turns away from the sphere, not into it.
    EXPECT_GT((c.subgoal - ahead[0].center).norm(), (Vec3(1, 1, 0).normalized() * c.r_outer_m - ahead[0].center).norm());
  }
}

TEST(SubgoalSelector, InnerRatioIsAParameterAndValidated) {
  const std::vector<StaticSphere> ahead = {{Vec3(1, 1, 0).normalized() * 1.6, 0.4}};
  SubgoalParams p;
  p.inner_ratio = 2.0 / 3.0;
  const SubgoalChoice c = selectSubgoal(towardGoal(&ahead), LocalParams::preset(Method::kTian2016), p);
  EXPECT_DOUBLE_EQ(c.r_inner_m, 2.0 / 3.0);
  EXPECT_GE(c.subgoal.norm(), c.r_inner_m - 1e-9);
  p.inner_ratio = 1.5;
  const SubgoalChoice bad = selectSubgoal(towardGoal(&ahead), LocalParams::preset(Method::kTian2016), p);
  EXPECT_EQ(bad.outcome, SubgoalOutcome::kInvalidInput);
  EXPECT_NE(bad.message.find("inner_ratio"), std::string::npos) << bad.message;
}

TEST(SubgoalSelector, NonFiniteInputAndNearTarget) {
  SubgoalQuery q = towardGoal(nullptr);
  q.velocity.x() = std::nan("");
  EXPECT_EQ(selectSubgoal(q, LocalParams::preset(Method::kTian2016), SubgoalParams{}).outcome,
            SubgoalOutcome::kInvalidInput);
  q = towardGoal(nullptr);
  q.target = Vec3(0.5, 0.2, 0);
  const SubgoalChoice c = selectSubgoal(q, LocalParams::preset(Method::kTian2016), SubgoalParams{});
  EXPECT_EQ(c.outcome, SubgoalOutcome::kTargetNear);
  EXPECT_EQ(c.subgoal, q.target);
}

// What a run hands the local planner (pickSubgoal): the sub-goal's bearing at the break point's
// distance. Far from obstacles that is the break point itself; near one the bearing of the
// annulus' minimum; bad input gives no point (the planner keeps steering at the break point).
TEST(SubgoalSelector, PickAimsAlongTheSubgoalsBearingAtTheBreakPointsDistance) {
  const LocalParams lp = LocalParams::preset(Method::kTian2016);
  local::RobotState st;
  const Vec3 a(0, 0, 0), b(14, 14, 0);
  const std::vector<StaticSphere> far = {{Vec3(10, 0, 0), 0.4}};
  local::SubgoalPick pick = pickSubgoal(st, a, b, nullptr, &far, nullptr, lp, SubgoalParams{});
  ASSERT_TRUE(pick.point);
  EXPECT_EQ(pick.kind, "straight");
  EXPECT_NEAR((pick.aim - b).norm(), 0.0, 1e-9);

  LocalParams lp2 = lp;
  lp2.robot.radius_m = 0.1;
  const std::vector<StaticSphere> ahead = {{Vec3(1, 1, 0).normalized() * 1.6, 0.4}};
  pick = pickSubgoal(st, a, b, nullptr, &ahead, nullptr, lp2, SubgoalParams{});
  ASSERT_TRUE(pick.point);
  EXPECT_EQ(pick.kind, "optimized");
  EXPECT_NEAR(pick.aim.norm(), b.norm(), 1e-9);
  EXPECT_NEAR(pick.aim.normalized().dot(pick.point->normalized()), 1.0, 1e-12);
  // Same input, same seed: the same sub-goal.
  EXPECT_EQ(*pick.point, *pickSubgoal(st, a, b, nullptr, &ahead, nullptr, lp2, SubgoalParams{}).point);

  st.velocity.x() = std::nan("");
  pick = pickSubgoal(st, a, b, nullptr, &ahead, nullptr, lp2, SubgoalParams{});
  EXPECT_FALSE(pick.point);
  EXPECT_EQ(pick.kind, "invalid_input");
}

}  // namespace
}  // namespace adit::fusion
