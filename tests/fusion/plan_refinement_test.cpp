// SPDX-License-Identifier: BSD-3-Clause
// refinePlan(): the global planner's path on a generated bend, refined in place - the planner's own
// motion check accepts every refined segment, the unrefined path and figures are kept, the same
// seed gives the same path; ground mode keeps heights; an unsolved plan is left alone.
#include "adit/fusion/plan_refinement.hpp"

#include <gtest/gtest.h>

#include <optional>

#include <cstdio>

#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::fusion {
namespace {

using map::Vec3;

struct Bend {
  map::SurveyNetwork net = test::bentRoadway(map::CrossSection::rectangle(4.0, 3.0), 0.2);
  map::OccupancyMap map = test::voxelizeOrFail(net);
  map::DistanceField field = std::move(map::DistanceField::build(map)).value();
};

const Bend& bend() {
  static const Bend b;
  return b;
}

global::GlobalPlanner planner(global::PlanMode mode) {
  global::GlobalPlannerParams p;
  p.robot = map::RobotShape::sphere(0.4);
  p.mode = mode;
  p.seed = 3;
  StatusOr<global::GlobalPlanner> g = global::GlobalPlanner::create(bend().map, bend().field, p, &bend().net);
  EXPECT_TRUE(g.ok()) << g.status().message();
  return std::move(g).value();
}

const Vec3 kStart(1.4, 0.5, 1.5), kGoal(18.5, 10.8, 2.5);

TEST(PlanRefinement, RefinesThePlannedPathInPlaceWithThePlannersCheck) {
  const global::GlobalPlanner g = planner(global::PlanMode::kFly);
  global::GlobalPlanResult r = g.plan(kStart, kGoal);
  ASSERT_TRUE(r.solved()) << r.message;
  const map::Polyline planned = r.path;
  const PlanRefinement ref = refinePlan(g, bend().field, &r);
  ASSERT_EQ(ref.outcome, RefineOutcome::kRefined) << ref.message;
  std::printf("bend, planned: length %.3f -> %.3f m, min clearance %.3f -> %.3f m, %zu break points, %d iterations, "
              "%.3f s\n",
              ref.before.length_m, ref.after.length_m, ref.before.min_clearance_m, ref.after.min_clearance_m,
              ref.before.break_points, ref.iterations, ref.time_s);
  // The unrefined path is kept as it was planned; the result holds the refined one and its figures.
  ASSERT_EQ(ref.before_path.size(), planned.size());
  for (std::size_t i = 0; i < planned.size(); ++i) EXPECT_EQ(ref.before_path.points[i], planned.points[i]);
  EXPECT_EQ(r.length_m, ref.after.length_m);
  EXPECT_EQ(r.min_clearance_m, ref.after.min_clearance_m);
  EXPECT_NEAR(ref.before.length_m, planned.length(), 1e-9);
  EXPECT_NEAR(ref.after.length_m, r.path.length(), 1e-9);
  EXPECT_LT(ref.objective_after, ref.objective_before);
  EXPECT_EQ(r.path.points.front(), kStart);
  EXPECT_EQ(r.path.points.back(), kGoal);
  // Exactly as valid as a planned path: the planner's motion check accepts it whole.
  const Status valid = g.validatePath(r.path);
  EXPECT_TRUE(valid.ok()) << valid.message();
  EXPECT_GT(ref.after.min_clearance_m, 0.0);
  EXPECT_GT(ref.time_s, 0.0);

  // Deterministic: the same plan refined again gives the same path, bit for bit.
  global::GlobalPlanResult again = g.plan(kStart, kGoal);
  refinePlan(g, bend().field, &again);
  ASSERT_EQ(again.path.size(), r.path.size());
  for (std::size_t i = 0; i < r.path.size(); ++i) EXPECT_EQ(again.path.points[i], r.path.points[i]);
}

// Ground mode: break points move sideways and stand on the floor where they land (the bend's floor
// rises, so a point moved along it is at another height), as the planner's own do; the path stays
// valid for the planner.
TEST(PlanRefinement, GroundModeMovesBreakPointsSidewaysOntoTheFloor) {
  const global::GlobalPlanner g = planner(global::PlanMode::kGround);
  global::GlobalPlanResult r = g.plan(Vec3(1.4, 0.5, 0.5), Vec3(18.5, 10.8, 1.5));
  ASSERT_TRUE(r.solved()) << r.message;
  const PlanRefinement ref = refinePlan(g, bend().field, &r);
  ASSERT_EQ(ref.outcome, RefineOutcome::kRefined) << ref.message;
  ASSERT_EQ(r.path.size(), ref.before_path.size());
  int moved = 0;
  for (std::size_t i = 0; i < r.path.size(); ++i) {
    const Vec3 p = r.path.points[i];
    if (p == ref.before_path.points[i]) continue;
    ++moved;
    const std::optional<Vec3> stand = g.standAt(p);
    ASSERT_TRUE(stand.has_value()) << "break point " << i << " has no floor";
    EXPECT_NEAR((*stand - p).norm(), 0.0, 1e-9) << "break point " << i << " does not stand on the floor";
  }
  EXPECT_GT(moved, 0);
  EXPECT_LT(ref.objective_after, ref.objective_before);
  const Status valid = g.validatePath(r.path);
  EXPECT_TRUE(valid.ok()) << valid.message();
}

TEST(PlanRefinement, UnsolvedPlanIsLeftAlone) {
  const global::GlobalPlanner g = planner(global::PlanMode::kFly);
  global::GlobalPlanResult r = g.plan(kStart, Vec3(10, -20, 1.5));  // goal in rock
  ASSERT_FALSE(r.solved());
  const global::GlobalPlanResult copy = r;
  const PlanRefinement ref = refinePlan(g, bend().field, &r);
  EXPECT_EQ(ref.outcome, RefineOutcome::kInvalidInput);
  EXPECT_FALSE(ref.message.empty());
  EXPECT_EQ(r.path.size(), copy.path.size());
  EXPECT_EQ(r.length_m, copy.length_m);
  EXPECT_EQ(refinePlan(g, bend().field, nullptr).outcome, RefineOutcome::kInvalidInput);
}

}  // namespace
}  // namespace adit::fusion
