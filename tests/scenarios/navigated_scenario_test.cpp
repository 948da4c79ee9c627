// SPDX-License-Identifier: BSD-3-Clause
// Issue 8's runs with the navigator (maps/scenarios/): the rescue run on the bundled district
// reroutes round a roof fall, the sealed roadway ends in no_route in seconds. The referee measures
// against the true world (the map plus the fall); the robot knew only what it sensed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "adit/fusion/navigated_simulation.hpp"

namespace adit::fusion {
namespace {

const std::string kDir = std::string(ADIT_MAPS_DIR) + "/scenarios/";

NavigatedRun run(const std::string& name) {
  StatusOr<local::Scenario> sc = local::loadScenario(kDir + name);
  EXPECT_TRUE(sc.ok()) << sc.status().message();
  if (!sc.ok()) return {};
  StatusOr<local::Environment> env = local::Environment::load(*sc);
  EXPECT_TRUE(env.ok()) << env.status().message();
  if (!env.ok()) return {};
  StatusOr<NavigatedRun> r = simulateNavigated(*sc, *env);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) return {};
  const local::SimulationResult& x = r->run;
  std::printf("[%s] %s t=%.1f s (end %.1f s), path %.1f m, min clearance %.3f m, fall clearance %.3f m, "
              "%d collisions, %d replans (longest %.3f s), cycle p50 %.1f us p99 %.1f us max %.1f us, wall %.2f s\n",
              sc->name.c_str(), local::outcomeName(x.outcome), x.arrival_time_s, r->end_time_s, x.path_length_m,
              x.min_clearance_m, r->min_fall_clearance_m, x.collisions, r->replans, r->max_replan_time_s,
              x.step_time_p50_us, x.step_time_p99_us, r->max_cycle_time_s * 1e6, r->wall_time_s);
  for (const NavigatorEvent& e : r->events) std::printf("    t=%.1f %s: %s\n", e.t_s, e.type.c_str(), e.reason.c_str());
  return *r;
}

TEST(NavigatedScenario, DistrictRescueReroutesThroughAnotherCrossCut) {
  const NavigatedRun r = run("district_rescue.yaml");
  EXPECT_EQ(r.run.outcome, local::Outcome::kArrived) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);
  EXPECT_GE(r.replans, 1);
  EXPECT_GT(r.run.min_clearance_m, 0.0);        // clear of rock, the fall included
  EXPECT_GT(r.min_fall_clearance_m, 0.0);       // clear of the fall itself
  ASSERT_FALSE(r.events.empty());
  EXPECT_EQ(r.events[0].type, "replan");
  // The new route leaves crosscut-90 (where the robot is, short of the fall) backwards and takes
  // crosscut-160 to the return airway.
  const std::vector<std::string>& route = r.events[0].route;
  ASSERT_FALSE(route.empty());
  EXPECT_EQ(route.front(), "crosscut-90");
  EXPECT_EQ(std::count(route.begin(), route.end(), "crosscut-90"), 1);
  EXPECT_NE(std::find(route.begin(), route.end(), "crosscut-160"), route.end());
  EXPECT_EQ(route.back(), "return-airway");
}

TEST(NavigatedScenario, SealedRoadwayEndsInNoRouteWithinSeconds) {
  const NavigatedRun r = run("sealed_roadway.yaml");
  EXPECT_EQ(r.run.outcome, local::Outcome::kNoRoute) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);
  EXPECT_LT(r.end_time_s, 20.0);  // simulated: stopped once the sensor saw the fall
  EXPECT_LT(r.wall_time_s, 10.0); // wall clock: a bound against a hang, not a speed measurement
  ASSERT_FALSE(r.events.empty());
  EXPECT_EQ(r.events.back().type, "no_route");
}

}  // namespace
}  // namespace adit::fusion
