// SPDX-License-Identifier: BSD-3-Clause
// The simulator's link to the sub-goal selector: a scenario's selection parameters. (The runs
// themselves are tested by the scenario tests, tests/scenarios.)
#include "adit/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::sim {
namespace {

// The suite keeps the selector's name: the test was written with it (tests/fusion) before
// subgoalParamsFor() moved to adit::sim with the Scenario it reads.
TEST(SubgoalSelector, ParamsForAScenarioTakeItsPeriodAndSeed) {
  Scenario sc;
  sc.subgoal_period_s = 0.5;
  sc.seed = 42;
  const fusion::SubgoalParams p = subgoalParamsFor(sc);
  EXPECT_EQ(p.t0_s, 0.5);
  EXPECT_EQ(p.optimizer.seed, 42u);
  EXPECT_TRUE(p.validate().ok());
}

// A flying robot weaving toward a roadway's rib and back, with a roof fall 15 m off: the referee's
// least clearance is the least, over the sub-samples it judged, of the exact rock distance
// (CollisionChecker, exact within 10 m) and the fall's. The referee reads the rock exactly only
// below the least clearance so far; this holds it to reading everything exactly.
TEST(Referee, LeastClearanceIsTheLeastExactDistanceOverItsSubSamples) {
  const map::OccupancyMap m = test::voxelizeOrFail(test::junctionNetwork(0.2));
  StatusOr<map::DistanceField> field = map::DistanceField::build(m);
  ASSERT_TRUE(field.ok());
  StatusOr<Environment> env = Environment::borrow(m, *field);
  ASSERT_TRUE(env.ok());
  Scenario sc;
  sc.params.robot.radius_m = 0.3;
  const Vec3 fall_centre(14, 10, 1.5);
  const double fall_radius = 1.0;
  std::vector<Vec3> judged;
  const ExtraDistanceFn fall = [&](const Vec3& p, double, double& d, std::string& what) {
    judged.push_back(p);
    const double df = std::max(0.0, (p - fall_centre).norm() - fall_radius - sc.params.robot.radius_m);
    if (df < d) {
      d = df;
      what = "roof fall";
    }
  };
  local::RobotState state;
  state.position = Vec3(1.0, 0.0, 1.2);
  state.velocity = Vec3(0.6, 0.0, 0.0);
  SimulationResult res;
  std::vector<double> least_so_far;
  for (int k = 0; k < 150; ++k) {
    // Toward y(t) = A sin(0.15 k), A growing from 1 to 1.6 m (the rib of the 4 m roadway is 2 m
    // off its axis), damped.
    const double t = k * sc.dt_s;
    const Vec3 acc(0.0, 4.0 * ((1.0 + 0.004 * k) * std::sin(0.15 * k) - state.position.y()) - 3.0 * state.velocity.y(), 0.0);
    refereePeriod(sc, *env, acc, t, state, res, fall);
    least_so_far.push_back(res.min_clearance_m);
  }
  ASSERT_GT(judged.size(), 150u);
  double oracle = std::numeric_limits<double>::infinity(), oracle_rock = oracle;
  for (const Vec3& p : judged) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = p;
    const map::ShapeDistance d = env->checker()->distance(map::RobotShape::sphere(sc.params.robot.radius_m), pose, 10.0);
    ASSERT_TRUE(d.exact || d.collision) << p.transpose();
    const double rock = d.collision ? 0.0 : d.distance_m;
    oracle_rock = std::min(oracle_rock, rock);
    oracle = std::min({oracle, rock, std::max(0.0, (p - fall_centre).norm() - fall_radius - sc.params.robot.radius_m)});
  }
  EXPECT_EQ(res.min_clearance_m, oracle);
  EXPECT_EQ(res.collisions, 0);
  // The run came near the rib more than once, ever nearer: later periods needed the rock exactly.
  EXPECT_LT(oracle_rock, 0.5);
  EXPECT_LT(least_so_far.back(), least_so_far[least_so_far.size() / 3]);
}

}  // namespace
}  // namespace adit::sim
