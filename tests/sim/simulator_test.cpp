// SPDX-License-Identifier: BSD-3-Clause
// The simulator's link to the sub-goal selector: a scenario's selection parameters. (The runs
// themselves are tested by the scenario tests, tests/scenarios.)
#include "adit/sim/simulator.hpp"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace adit::sim
