// SPDX-License-Identifier: BSD-3-Clause
// The bundled runs with the navigator (maps/scenarios/), by the tracked ground robot they are
// written for and flying beside it: the rescue run on the bundled district reroutes round a roof
// fall, the sealed roadway ends in no_route in seconds, the inspection run along the main haulage
// roadway passes an oncoming machine (flying, on a refined expected path). The referee measures
// against the true world (the map plus the fall); the robot knew only what it sensed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "adit/sim/navigated_simulation.hpp"

namespace adit::fusion {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is adit::fusion's.
using namespace adit::sim;

const std::string kDir = std::string(ADIT_MAPS_DIR) + "/scenarios/";

// `truth`, when given, keeps the true world the run was refereed in.
NavigatedRun run(const std::string& name, std::optional<sim::Environment>* truth = nullptr) {
  StatusOr<sim::Scenario> sc = sim::loadScenario(kDir + name);
  EXPECT_TRUE(sc.ok()) << sc.status().message();
  if (!sc.ok()) return {};
  StatusOr<sim::Environment> env = sim::Environment::load(*sc);
  EXPECT_TRUE(env.ok()) << env.status().message();
  if (!env.ok()) return {};
  StatusOr<NavigatedRun> r = simulateNavigated(*sc, *env);
  if (truth) truth->emplace(std::move(env).value());
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) return {};
  const sim::SimulationResult& x = r->run;
  std::printf("[%s] %s t=%.1f s (end %.1f s), path %.1f m, min clearance %.3f m, fall clearance %.3f m, "
              "%d collisions, %d replans (longest %.3f s), cycle p50 %.1f us p99 %.1f us max %.1f us, wall %.2f s\n",
              sc->name.c_str(), sim::outcomeName(x.outcome), x.arrival_time_s, r->end_time_s, x.path_length_m,
              x.min_clearance_m, r->min_fall_clearance_m, x.collisions, r->replans, r->max_replan_time_s,
              x.step_time_p50_us, x.step_time_p99_us, r->max_cycle_time_s * 1e6, r->wall_time_s);
  for (const NavigatorEvent& e : r->events) std::printf("    t=%.1f %s: %s\n", e.t_s, e.type.c_str(), e.reason.c_str());
  if (r->refinement) {
    const PlanRefinement& f = *r->refinement;
    std::printf("    refinement %s in %.3f s: length %.2f -> %.2f m, min clearance %.3f -> %.3f m, %zu break points\n",
                refineOutcomeName(f.outcome), f.time_s, f.before.length_m, f.after.length_m, f.before.min_clearance_m,
                f.after.min_clearance_m, f.before.break_points);
  }
  for (const sim::ClosestApproach& c : x.closest)
    std::printf("    closest approach to %s: %.3f m at t=%.1f s\n", c.name.c_str(), c.distance_m, c.t_s);
  return *r;
}

// Every sample stands on the floor: the centre half the robot's height (0.3 m) above the rock
// under it (a voxel of quantisation on the sloping roadways).
void expectOnTheFloor(const NavigatedRun& r, const sim::Environment& truth) {
  const map::DistanceField& field = *truth.field();
  for (const sim::TrajectorySample& s : r.run.trajectory) {
    double floor = s.position.z();
    while (field.isFree(map::Vec3(s.position.x(), s.position.y(), floor)) && floor > s.position.z() - 3.0)
      floor -= 0.01;
    EXPECT_NEAR(s.position.z() - floor, 0.3, field.resolution() + 0.011) << "t = " << s.t_s;
  }
}

// The rescue run, flying (the papers' sphere) and as the tracked ground robot a mine rescue robot
// is (the bundled run): both learn of the fall only inside crosscut-90 and reroute through
// crosscut-160; the ground robot, on the floor all the way, finds the rubble no way through and
// arrives within 10 % of the flying run's time.
TEST(NavigatedScenario, DistrictRescueReroutesThroughAnotherCrossCut) {
  std::optional<sim::Environment> truth;
  const NavigatedRun ground = run("district_rescue.yaml", &truth);
  const NavigatedRun fly = run("district_rescue_fly.yaml");
  for (const NavigatedRun* r : {&ground, &fly}) {
    SCOPED_TRACE(r == &ground ? "ground" : "fly");
    EXPECT_EQ(r->run.outcome, sim::Outcome::kArrived) << r->run.message;
    EXPECT_EQ(r->run.collisions, 0);
    EXPECT_GE(r->replans, 1);
    EXPECT_GT(r->run.min_clearance_m, 0.0);   // clear of rock, the fall included
    EXPECT_GT(r->min_fall_clearance_m, 0.0);  // clear of the fall itself
    ASSERT_FALSE(r->events.empty());
    for (const NavigatorEvent& e : r->events) EXPECT_EQ(e.type, "replan");
    // The last route takes crosscut-160 to the return airway. (A first replan may still go
    // through the fall when the first sensed fringe of it leaves a gap; the next cycle sees more.)
    const std::vector<std::string>& route = r->events.back().route;
    ASSERT_FALSE(route.empty());
    EXPECT_LE(std::count(route.begin(), route.end(), "crosscut-90"), 1);
    EXPECT_NE(std::find(route.begin(), route.end(), "crosscut-160"), route.end());
    EXPECT_EQ(route.back(), "return-airway");
  }
  // The flying robot leaves crosscut-90 (where it is, short of the fall) backwards.
  ASSERT_FALSE(fly.events.empty());
  EXPECT_EQ(fly.events.back().route.front(), "crosscut-90");
  EXPECT_LE(ground.run.arrival_time_s, 1.1 * fly.run.arrival_time_s);
  ASSERT_TRUE(truth.has_value());
  expectOnTheFloor(ground, *truth);
}

TEST(NavigatedScenario, SealedRoadwayEndsInNoRouteWithinSeconds) {
  const NavigatedRun r = run("sealed_roadway.yaml");
  EXPECT_EQ(r.run.outcome, sim::Outcome::kNoRoute) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);
  EXPECT_LT(r.end_time_s, 20.0);  // simulated: stopped once the sensor saw the fall
  EXPECT_LT(r.wall_time_s, 10.0); // wall clock: a bound against a hang, not a speed measurement
  ASSERT_FALSE(r.events.empty());
  EXPECT_EQ(r.events.back().type, "no_route");
  // What a replay needs: each replan's path at its time, and the fall's rock when it was seen.
  std::size_t replans = 0;
  for (const NavigatorEvent& e : r.events)
    if (e.type == "replan") {
      ++replans;
      bool found = false;
      for (const NavigatedRun::PathChange& c : r.path_changes)
        found = found || (c.t_s == e.t_s && !c.path.points.empty());
      EXPECT_TRUE(found) << "no path recorded for the replan at t = " << e.t_s;
    }
  EXPECT_GE(r.path_changes.size(), replans);
  ASSERT_FALSE(r.sensed.empty());
  const Vec3 fall(20.0, 0.0, 1.6);  // the scenario's ball
  for (std::size_t k = 0; k < r.sensed.size(); ++k) {
    EXPECT_LE(r.sensed[k].t_s, r.end_time_s);
    if (k > 0) {
      EXPECT_GE(r.sensed[k].t_s, r.sensed[k - 1].t_s);
    }
    EXPECT_NEAR((r.sensed[k].point - fall).norm(), 3.0, 0.5) << "sensed point " << k << " is not on the fall";
  }
}

// The inspection run: most of the main haulage roadway (x = 25 -> 580 m) on the refined expected
// path, a machine coming the other way; flying (the sphere the refinement's claims are about).
TEST(NavigatedScenario, DistrictInspectionPassesTheOncomingMachineOnARefinedPath) {
  std::optional<sim::Environment> truth;
  const NavigatedRun r = run("district_inspection_fly.yaml", &truth);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(r.run.outcome, sim::Outcome::kArrived) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);  // with rock and with the machine
  EXPECT_GT(r.run.min_clearance_m, 0.0);
  ASSERT_EQ(r.run.closest.size(), 1u);
  EXPECT_EQ(r.run.closest[0].name, "machine");
  EXPECT_GT(r.run.closest[0].distance_m, 0.0);
  EXPECT_EQ(r.replans, 0);

  // The expected path was planned and refined; initial_path is the refined one.
  ASSERT_TRUE(r.refinement.has_value());
  const PlanRefinement& f = *r.refinement;
  ASSERT_EQ(f.outcome, RefineOutcome::kRefined) << f.message;
  EXPECT_GE(f.before.break_points, 1u);
  EXPECT_NEAR(r.initial_path.length(), f.after.length_m, 1e-9);
  EXPECT_NEAR(f.before_path.length(), f.before.length_m, 1e-9);
  // The refiner minimises length + w x clearance penalty (w = the planner's clearance_weight):
  // lower objective and more clearance. The planned path along a straight roadway is close to the
  // shortest already, so the refinement may pay for clearance with a few centimetres of length;
  // it may never pay more than the penalty it removes (the objective).
  EXPECT_LT(f.objective_after, f.objective_before);
  EXPECT_GE(f.after.min_clearance_m, f.before.min_clearance_m);
  std::printf("    refined - unrefined length: %+.3f m (%+.4f %%)\n", f.after.length_m - f.before.length_m,
              100.0 * (f.after.length_m - f.before.length_m) / f.before.length_m);

  // Still clear, measured on the true map: every point of the refined path (a quarter voxel apart)
  // keeps the robot's sphere out of rock.
  const map::DistanceField& field = *truth->field();
  const double radius = 0.4;  // the scenario's robot.radius
  double lowest = 1e9;
  for (std::size_t i = 0; i + 1 < r.initial_path.size(); ++i) {
    const Vec3 a = r.initial_path.points[i], b = r.initial_path.points[i + 1];
    const int n = int(std::ceil((b - a).norm() / (0.25 * field.resolution())));
    for (int k = 0; k <= n; ++k) lowest = std::min(lowest, field.distance(a + (b - a) * (double(k) / n)));
  }
  std::printf("    refined path: field distance >= %.3f m (robot radius %.1f m)\n", lowest, radius);
  EXPECT_GT(lowest, radius + 0.5 * field.resolution());
  // The run's clearance from rock alone (min_clearance counts the machine too), from the field.
  double rock = 1e9;
  for (const sim::TrajectorySample& s : r.run.trajectory) rock = std::min(rock, field.distance(s.position) - radius);
  std::printf("    trajectory: clearance from rock >= %.3f m\n", rock);
  EXPECT_GT(rock, 0.0);
}

// The bundled inspection run: the tracked ground robot on the floor all the way, past the oncoming
// machine without contact, no replan, within 10 % of the flying run's time.
TEST(NavigatedScenario, DistrictInspectionByATrackedGroundRobotPassesTheMachineOnTheFloor) {
  std::optional<sim::Environment> truth;
  const NavigatedRun r = run("district_inspection.yaml", &truth);
  const NavigatedRun fly = run("district_inspection_fly.yaml");
  EXPECT_EQ(r.run.outcome, sim::Outcome::kArrived) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);
  EXPECT_EQ(r.replans, 0);
  EXPECT_GT(r.run.min_clearance_m, 0.0);
  ASSERT_EQ(r.run.closest.size(), 1u);
  EXPECT_GT(r.run.closest[0].distance_m, 0.0);
  EXPECT_LE(r.run.arrival_time_s, 1.1 * fly.run.arrival_time_s);
  ASSERT_TRUE(truth.has_value());
  expectOnTheFloor(r, *truth);
}

}  // namespace
}  // namespace adit::fusion
