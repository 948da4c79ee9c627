// SPDX-License-Identifier: BSD-3-Clause
// Randomized batch scenarios (issue 8): every draw from (seed, index) alone, runs independent of
// their order, honest outcomes.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "adit/fusion/batch.hpp"
#include "adit/map/distance_field.hpp"

namespace adit::fusion {
namespace {

const std::string kDistrict = std::string(ADIT_MAPS_DIR) + "/district.yaml";

class BatchTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    StatusOr<local::Scenario> sc = local::parseScenario(
        "map: " + kDistrict +
            "\nstart: [0, 0, 0]\ngoal: [1, 0, 0]\nexpected_path: plan\n"
            "robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 8}\nmethod: tian2016\n"
            "params: {rho0_m: 1.0}\ndt: 0.1\n",
        "batch_test");
    ASSERT_TRUE(sc.ok()) << sc.status().toString();
    base_ = new local::Scenario(*sc);
    StatusOr<map::SurveyNetwork> net = map::loadSurvey(kDistrict);
    ASSERT_TRUE(net.ok()) << net.status().toString();
    survey_ = new map::SurveyNetwork(*net);
    StatusOr<local::Environment> env = local::Environment::load(*base_);
    ASSERT_TRUE(env.ok()) << env.status().toString();
    truth_ = new local::Environment(std::move(*env));
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete survey_;
    delete base_;
  }
  static BatchParams shortRuns() {
    BatchParams p;
    p.seed = 42;
    p.max_separation_m = 35.0;
    p.t_max_s = 60.0;
    return p;
  }
  static local::Scenario* base_;
  static map::SurveyNetwork* survey_;
  static local::Environment* truth_;
};
local::Scenario* BatchTest::base_ = nullptr;
map::SurveyNetwork* BatchTest::survey_ = nullptr;
local::Environment* BatchTest::truth_ = nullptr;

TEST(BatchSeed, DependsOnSeedAndIndexOnly) {
  EXPECT_EQ(batchRunSeed(7, 3), batchRunSeed(7, 3));
  EXPECT_NE(batchRunSeed(7, 3), batchRunSeed(7, 4));
  EXPECT_NE(batchRunSeed(7, 3), batchRunSeed(8, 3));
}

TEST(BatchParamsTest, RefusesBadValues) {
  BatchParams p;
  EXPECT_TRUE(p.validate().ok());
  p.max_separation_m = 5.0;  // below the minimum
  EXPECT_FALSE(p.validate().ok());
  p = BatchParams();
  p.roof_fall_probability = 1.5;
  EXPECT_FALSE(p.validate().ok());
}

TEST_F(BatchTest, ScenariosAreDrawnOnTheRoadwaysAndDoNotDependOnOrder) {
  const BatchParams p = shortRuns();
  std::vector<local::Scenario> forward;
  for (int i = 0; i < 20; ++i) {
    StatusOr<local::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok()) << sc.status().toString();
    forward.push_back(*sc);
  }
  int falls = 0, vehicles = 0;
  for (int i = 19; i >= 0; --i) {
    StatusOr<local::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok());
    const local::Scenario& f = forward[std::size_t(i)];
    EXPECT_EQ(sc->start, f.start);
    EXPECT_EQ(sc->goal, f.goal);
    EXPECT_EQ(sc->seed, f.seed);
    ASSERT_EQ(sc->moving_obstacles.size(), f.moving_obstacles.size());
    ASSERT_EQ(sc->events.size(), f.events.size());
    const double d = (f.goal - f.start).norm();
    EXPECT_GE(d, p.min_separation_m);
    EXPECT_LE(d, p.max_separation_m);
    EXPECT_TRUE(truth_->field()->isFree(f.start));
    EXPECT_TRUE(truth_->field()->isFree(f.goal));
    EXPECT_TRUE(f.plan_expected_path);
    EXPECT_LE(f.moving_obstacles.size(), 3u);
    falls += int(f.events.size());
    vehicles += int(f.moving_obstacles.size());
  }
  // 20 draws with probability 1/2 of a fall and 0..3 vehicles: some of each.
  EXPECT_GT(falls, 0);
  EXPECT_GT(vehicles, 0);
}

// Runs in reverse order give the same deterministic columns as in order (the planner reseeds per
// plan), no arrival collided and every arrival ends within the tolerance of the goal.
TEST_F(BatchTest, RunsAreHonestAndIndependentOfOrder) {
  const BatchParams p = shortRuns();
  constexpr int kRuns = 2;
  std::vector<BatchRunResult> forward, backward(kRuns);
  for (int i = 0; i < kRuns; ++i) {
    StatusOr<local::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok());
    forward.push_back(runBatchScenario(*sc, *truth_, i));
  }
  for (int i = kRuns - 1; i >= 0; --i) {
    StatusOr<local::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok());
    backward[std::size_t(i)] = runBatchScenario(*sc, *truth_, i);
  }
  for (int i = 0; i < kRuns; ++i) {
    const BatchRunResult& a = forward[std::size_t(i)];
    const BatchRunResult& b = backward[std::size_t(i)];
    EXPECT_NE(a.outcome, "error") << a.message;
    EXPECT_EQ(a.outcome, b.outcome) << "run " << i;
    EXPECT_EQ(a.path_length_m, b.path_length_m) << "run " << i;
    EXPECT_EQ(a.replans, b.replans) << "run " << i;
    if (a.outcome == "arrived") {
      EXPECT_EQ(a.collisions, 0) << "run " << i;
      EXPECT_LE(a.final_goal_distance_m, 0.5) << "run " << i;
    }
    // The CSV row has the nine columns.
    const std::string row = batchCsvRow(a);
    EXPECT_EQ(std::count(row.begin(), row.end(), ','), 8) << row;
  }
}

}  // namespace
}  // namespace adit::fusion
