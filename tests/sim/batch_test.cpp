// SPDX-License-Identifier: BSD-3-Clause
// Randomized batch scenarios (issue 8): every draw from (seed, index) alone, runs independent of
// their order, honest outcomes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/sim/batch.hpp"
#include "adit/sim/simulator.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::sim {
namespace {

const std::string kDistrict = std::string(ADIT_MAPS_DIR) + "/district.yaml";

class BatchTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    StatusOr<sim::Scenario> sc = sim::parseScenario(
        "map: " + kDistrict +
            "\nstart: [0, 0, 0]\ngoal: [1, 0, 0]\nexpected_path: plan\n"
            "robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 8}\nmethod: tian2016\n"
            "params: {rho0_m: 1.0}\ndt: 0.1\n",
        "batch_test");
    ASSERT_TRUE(sc.ok()) << sc.status().toString();
    base_ = new sim::Scenario(*sc);
    StatusOr<map::SurveyNetwork> net = map::loadSurvey(kDistrict);
    ASSERT_TRUE(net.ok()) << net.status().toString();
    survey_ = new map::SurveyNetwork(*net);
    StatusOr<sim::Environment> env = sim::Environment::load(*base_);
    ASSERT_TRUE(env.ok()) << env.status().toString();
    truth_ = new sim::Environment(std::move(*env));
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
  static sim::Scenario* base_;
  static map::SurveyNetwork* survey_;
  static sim::Environment* truth_;
};
sim::Scenario* BatchTest::base_ = nullptr;
map::SurveyNetwork* BatchTest::survey_ = nullptr;
sim::Environment* BatchTest::truth_ = nullptr;

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
  std::vector<sim::Scenario> forward;
  for (int i = 0; i < 20; ++i) {
    StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok()) << sc.status().toString();
    forward.push_back(*sc);
  }
  int falls = 0, vehicles = 0;
  for (int i = 19; i >= 0; --i) {
    StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok());
    const sim::Scenario& f = forward[std::size_t(i)];
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

// A share of the goals is moved beside the floor or a rib (issue 20), from a stream of its own:
// with every goal moved (share 1), each goal that moved is radius + margin + 0.1..0.5 m from rock
// (within the march's 2 cm), and everything else of every run is what it is without (share 0).
TEST_F(BatchTest, NearRockGoalsMoveOnlyTheGoal) {
  BatchParams none = shortRuns(), all = shortRuns();
  none.near_rock_goal_share = 0.0;
  all.near_rock_goal_share = 1.0;
  const double r = base_->params.robot.radius_m, margin = 0.2;
  int moved = 0;
  for (int i = 0; i < 20; ++i) {
    StatusOr<sim::Scenario> a = makeBatchScenario(*base_, *survey_, *truth_, none, i);
    StatusOr<sim::Scenario> b = makeBatchScenario(*base_, *survey_, *truth_, all, i);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->start, b->start);
    EXPECT_EQ(a->t_max_s, b->t_max_s);
    ASSERT_EQ(a->moving_obstacles.size(), b->moving_obstacles.size());
    for (std::size_t k = 0; k < a->moving_obstacles.size(); ++k)
      EXPECT_EQ(a->moving_obstacles[k].obstacle.position, b->moving_obstacles[k].obstacle.position);
    ASSERT_EQ(a->events.size(), b->events.size());
    for (std::size_t k = 0; k < a->events.size(); ++k) EXPECT_EQ(a->events[k].center, b->events[k].center);
    EXPECT_EQ(b->expected_path.points.back(), b->goal);
    if (a->goal == b->goal) continue;  // kept on the axis (near a fall, or out of the separation range)
    ++moved;
    const double c = truth_->field()->distance(b->goal);
    EXPECT_GE(c, r + margin + 0.1 - 1e-9) << i;
    EXPECT_LE(c, r + margin + 0.5 + 0.03) << i;
  }
  EXPECT_GE(moved, 15);
  StatusOr<BatchParams> parsed = parseBatchParams("near_rock_goals: 0.3\n", "gen.yaml");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  EXPECT_EQ(parsed->near_rock_goal_share, 0.3);
  EXPECT_EQ(BatchParams().near_rock_goal_share, 0.2);  // the documented share
  EXPECT_FALSE(parseBatchParams("near_rock_goals: 2\n", "gen.yaml").ok());
}

// Runs in reverse order give the same deterministic columns as in order (the planner reseeds per
// plan), no arrival collided and every arrival ends within the tolerance of the goal.
TEST_F(BatchTest, RunsAreHonestAndIndependentOfOrder) {
  const BatchParams p = shortRuns();
  constexpr int kRuns = 2;
  std::vector<BatchRunResult> forward, backward(kRuns);
  for (int i = 0; i < kRuns; ++i) {
    StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    ASSERT_TRUE(sc.ok());
    forward.push_back(runBatchScenario(*sc, *truth_, i));
  }
  for (int i = kRuns - 1; i >= 0; --i) {
    StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, i);
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
    // The CSV row has the header's 19 columns and reads back as the run, to its 3 decimals.
    const std::string row = batchCsvRow(a);
    EXPECT_EQ(std::count(row.begin(), row.end(), ','), 18) << row;
    EXPECT_EQ(a.end_cause != sim::EndCause::kNone, a.outcome == "timeout" || a.outcome == "stuck") << row;
    StatusOr<BatchRunResult> back = parseBatchCsvRow(row);
    ASSERT_TRUE(back.ok()) << back.status().message() << "\n" << row;
    EXPECT_EQ(batchCsvRow(*back), row);
    EXPECT_EQ(back->index, a.index);
    EXPECT_EQ(back->seed, a.seed);
    EXPECT_EQ(back->outcome, a.outcome);
    EXPECT_NEAR(back->path_length_m, a.path_length_m, 5e-4);
    EXPECT_EQ(back->collisions, a.collisions);
    EXPECT_EQ(back->vehicles, a.vehicles);
    EXPECT_EQ(back->roof_fall, a.roof_fall);
    EXPECT_EQ(back->end_cause, a.end_cause);
  }
}

// The two stuck ends of the 2,000-scenario district campaign (seed 1, the default generator):
// a roof fall beside a junction leaves a gap between the fall and the rib's corner that the global
// layer proves passable; the field, pulled back by rock on both sides, stalled in it through 3
// escapes x 3 replans. The first escape now pursues the path (PursuitParams::escape_run_m): both
// arrive, without contact; without it both are stuck again.
TEST_F(BatchTest, AFirstEscapePursuesThePathThroughAGapBesideARoofFall) {
  BatchParams p;
  p.seed = 1;
  for (const int index : {1823, 1911}) {
    StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, p, index);
    ASSERT_TRUE(sc.ok()) << sc.status().message();
    ASSERT_FALSE(sc->events.empty()) << "scenario " << index << " has its roof fall";
    const BatchRunResult with = runBatchScenario(*sc, *truth_, index);
    EXPECT_EQ(with.outcome, "arrived") << index << ": " << with.message;
    EXPECT_EQ(with.collisions, 0) << index;
    sim::Scenario field_only = *sc;
    field_only.params.pursuit.escape_run_m = 0.0;
    const BatchRunResult without = runBatchScenario(field_only, *truth_, index);
    EXPECT_EQ(without.outcome, "stuck") << index << ": " << without.message;
    EXPECT_EQ(without.end_cause, sim::EndCause::kEnRoute) << index;
  }
}

// The CSV reader for untrusted rows (campaign merge): every column checked, named on refusal.
TEST(BatchCsvRow, RefusesWhatARunCannotHaveWritten) {
  const std::string good = "3,42,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,";
  StatusOr<BatchRunResult> r = parseBatchCsvRow(good);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->index, 3);
  EXPECT_EQ(r->seed, 42u);
  EXPECT_DOUBLE_EQ(r->arrival_time_s, 12.5);
  EXPECT_TRUE(r->roof_fall);
  EXPECT_DOUBLE_EQ(r->roadway_width_m, 4.0);
  EXPECT_EQ(r->end_cause, sim::EndCause::kNone);
  // Empty where a run writes none: a timeout has no arrival time, a run no clearance sample.
  EXPECT_EQ(parseBatchCsvRow("3,42,stuck,,30.250,,1,1.200,15.000,0,2.000,0.500,2,0,25.000,0.400,1.000,4.000,short_of_goal")
                ->end_cause,
            sim::EndCause::kShortOfGoal);
  EXPECT_TRUE(std::isnan(parseBatchCsvRow("3,42,timeout,,30.250,,1,1.200,15.000,0,,0.500,2,0,25.000,0.400,1.000,4.000,en_route")
                             ->arrival_time_s));
  const std::pair<const char*, const char*> bad[] = {
      {"3,42,arrived,12.5", "4 columns, expected 19"},
      {"3,42,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,,9", "more than 19"},
      {"-3,42,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,", "column 1 (index)"},
      {"3,18446744073709551616,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,",
       "column 2 (seed): '18446744073709551616' is beyond"},
      {"3,42,flew,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,", "is not an outcome"},
      {"3,42,arrived,12.500,nan,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,", "column 5 (path_length)"},
      {"3,42,arrived,12.500,1e300,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,", "column 5 (path_length)"},
      {"3,42,arrived,12.500,2000000000.0,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,",
       "column 5 (path_length): '2000000000.0' is out of range"},
      {"3,42,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,7,25.000,0.400,1.000,4.000,", "column 14 (roof_fall)"},
      // The end cause: one of the names, given exactly for timeout and stuck rows.
      {"3,42,timeout,,30.250,0.800,1,1.200,15.000,0,9.000,0.500,2,1,25.000,0.400,1.000,4.000,lost", "is not an end cause"},
      {"3,42,timeout,,30.250,0.800,1,1.200,15.000,0,9.000,0.500,2,1,25.000,0.400,1.000,4.000,",
       "column 19 (end_cause): '' is empty for a timeout or stuck run"},
      {"3,42,arrived,12.500,30.250,0.800,1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,en_route",
       "is given for an outcome that has none"},
      {"3,42,arrived,12.500,30.250,0.800, 1,1.200,15.000,0,0.100,0.500,2,1,25.000,0.400,1.000,4.000,", "column 7 (replans)"},
  };
  for (const auto& [row, why] : bad) {
    StatusOr<BatchRunResult> refused = parseBatchCsvRow(row);
    ASSERT_FALSE(refused.ok()) << row;
    EXPECT_NE(refused.status().message().find(why), std::string::npos) << refused.status().message();
  }
}

// The campaign generator's YAML (issue 9): every key maps onto BatchParams; mistakes name the
// file, line and key.
TEST(BatchParamsTest, ParsesTheGeneratorYaml) {
  StatusOr<BatchParams> p = parseBatchParams(
      "separation: [10, 40]\nmax_moving_obstacles: 2\nvehicle_speed: [0.1, 0.5]\nvehicle_radius: 0.8\n"
      "roof_fall: {probability: 0.25, radius: 2.0}\nrobot_radius: [0.3, 0.5]\nrobot_speed: [0.8, 1.2]\nt_max: 90\n",
      "gen.yaml");
  ASSERT_TRUE(p.ok()) << p.status().toString();
  const std::vector<std::pair<double, double>> got_expected = {
      {p->min_separation_m, 10.0},     {p->max_separation_m, 40.0},    {double(p->max_moving_obstacles), 2.0},
      {p->vehicle_speed_min_mps, 0.1}, {p->vehicle_speed_max_mps, 0.5}, {p->vehicle_radius_m, 0.8},
      {p->roof_fall_probability, 0.25}, {p->roof_fall_radius_m, 2.0},  {p->robot_radius_min_m, 0.3},
      {p->robot_radius_max_m, 0.5},    {p->robot_speed_min_mps, 0.8},  {p->robot_speed_max_mps, 1.2},
      {p->t_max_s, 90.0}};
  for (std::size_t k = 0; k < got_expected.size(); ++k)
    EXPECT_EQ(got_expected[k].first, got_expected[k].second) << "field " << k;
  // Empty: the defaults (those of `adit simulate --batch`).
  StatusOr<BatchParams> d = parseBatchParams("", "empty.yaml");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->max_separation_m, BatchParams().max_separation_m);
  EXPECT_EQ(d->robot_radius_max_m, 0.0);

  auto error = [](const std::string& text) {
    StatusOr<BatchParams> r = parseBatchParams(text, "gen.yaml");
    return r.ok() ? std::string("accepted") : r.status().message();
  };
  EXPECT_NE(error("t_max: 60\nrobot_sped: [1, 2]\n").find("gen.yaml:2: robot_sped: unknown key"), std::string::npos);
  EXPECT_NE(error("separation: [40, 10]\n").find("gen.yaml:1: separation: min > max"), std::string::npos);
  EXPECT_NE(error("vehicle_radius: fast\n").find("vehicle_radius: expected a number (got 'fast')"), std::string::npos);
  EXPECT_NE(error("max_moving_obstacles: 2.5\n").find("expected an integer"), std::string::npos);
  EXPECT_NE(error("roof_fall: {probability: 2}\n").find("roof_fall_probability must be in [0, 1]"), std::string::npos);
  EXPECT_NE(error("robot_speed: [0, 1]\n").find("robot speed range"), std::string::npos);
  EXPECT_NE(error("[1, 2]\n").find("must be a YAML mapping"), std::string::npos);
  EXPECT_NE(error("separation: [10, 40\n").find("gen.yaml:"), std::string::npos);
}

// The generator's robot: a scenario's `robot:` mapping, read by the scenario reader (its keys,
// ranges and messages), kept as JSON for the campaign's identity, and applied to every scenario.
TEST_F(BatchTest, GeneratorRobotReplacesTheBaseRobot) {
  StatusOr<BatchParams> p = parseBatchParams(
      "t_max: 90\nrobot: {mode: ground, drive: skid, footprint: \"box:1.0,0.7\", height: 0.6, v_max: 0.8}\n", "gen.yaml");
  ASSERT_TRUE(p.ok()) << p.status().toString();
  EXPECT_EQ(p->robot_json, "{\"mode\": \"ground\", \"drive\": \"skid\", \"footprint\": \"box:1.0,0.7\", \"height\": 0.6, \"v_max\": 0.8}");
  // JSON is YAML: the identity's generator object reads back to the same robot.
  StatusOr<BatchParams> again = parseBatchParams("{\"robot\": " + p->robot_json + "}", "identity");
  ASSERT_TRUE(again.ok()) << again.status().toString();
  EXPECT_EQ(again->robot_json, p->robot_json);
  BatchParams q = shortRuns();
  q.robot_json = p->robot_json;
  StatusOr<sim::Scenario> sc = makeBatchScenario(*base_, *survey_, *truth_, q, 3);
  ASSERT_TRUE(sc.ok()) << sc.status().toString();
  const local::RobotLimits& r = sc->params.robot;
  EXPECT_TRUE(r.ground());
  EXPECT_EQ(r.drive, local::DriveType::kSkid);
  EXPECT_TRUE(r.footprint.box);
  EXPECT_DOUBLE_EQ(r.radius_m, r.footprint.circumradius());
  EXPECT_DOUBLE_EQ(r.v_max_mps, 0.8);
  EXPECT_EQ(sc->sensor_range_m, base_->sensor_range_m) << "no sensor_range given: the base's";
  // Start and goal are drawn as without it (its own draws come after).
  StatusOr<sim::Scenario> plain = makeBatchScenario(*base_, *survey_, *truth_, shortRuns(), 3);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(sc->start, plain->start);

  auto error = [](const std::string& text) {
    StatusOr<BatchParams> got = parseBatchParams(text, "gen.yaml");
    return got.ok() ? std::string("accepted") : got.status().message();
  };
  EXPECT_NE(error("\nrobot: {mode: ground, height: -1}\n").find("gen.yaml:2: robot: robot.height"), std::string::npos)
      << error("\nrobot: {mode: ground, height: -1}\n");
  EXPECT_NE(error("robot: {mode: walk}\n").find("robot.mode"), std::string::npos);
  EXPECT_NE(error("robot: {wheels: 4}\n").find("robot.wheels"), std::string::npos) << error("robot: {wheels: 4}\n");
  EXPECT_NE(error("robot: [1, 2]\n").find("expected a mapping"), std::string::npos);
  EXPECT_NE(error("robot: {mode: ground}\nrobot_radius: [0.3, 0.5]\n").find("footprint"), std::string::npos);
}

// Robot ranges: every scenario's robot inside them, the same for the same index, and drawn from
// a stream of their own (the vehicles, drawn after start and goal, come out the same whenever
// start and goal do).
TEST_F(BatchTest, RobotRangesAreDrawnPerScenario) {
  BatchParams p = shortRuns();
  p.robot_radius_min_m = 0.3;
  p.robot_radius_max_m = 0.5;
  p.robot_speed_min_mps = 0.8;
  p.robot_speed_max_mps = 1.2;
  std::vector<double> radii;
  int same_draws = 0;
  for (int i = 0; i < 10; ++i) {
    StatusOr<sim::Scenario> a = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    StatusOr<sim::Scenario> b = makeBatchScenario(*base_, *survey_, *truth_, p, i);
    StatusOr<sim::Scenario> plain = makeBatchScenario(*base_, *survey_, *truth_, shortRuns(), i);
    ASSERT_TRUE(a.ok() && b.ok() && plain.ok());
    const local::RobotLimits& r = a->params.robot;
    EXPECT_GE(r.radius_m, 0.3);
    EXPECT_LE(r.radius_m, 0.5);
    EXPECT_GE(r.v_max_mps, 0.8);
    EXPECT_LE(r.v_max_mps, 1.2);
    EXPECT_EQ(r.radius_m, b->params.robot.radius_m);
    EXPECT_EQ(r.v_max_mps, b->params.robot.v_max_mps);
    EXPECT_EQ(plain->params.robot.radius_m, base_->params.robot.radius_m);
    if (a->start == plain->start && a->goal == plain->goal) {
      ++same_draws;
      ASSERT_EQ(a->moving_obstacles.size(), plain->moving_obstacles.size());
      for (std::size_t k = 0; k < a->moving_obstacles.size(); ++k)
        EXPECT_EQ(a->moving_obstacles[k].obstacle.position, plain->moving_obstacles[k].obstacle.position);
    }
    radii.push_back(r.radius_m);
  }
  EXPECT_GT(same_draws, 0);
  std::sort(radii.begin(), radii.end());
  EXPECT_LT(radii.front(), radii.back());
}

// The roadway-width feature: the section of the nearest roadway at the robot's centre height.
TEST_F(BatchTest, RoadwayWidthIsTheNearestRoadwaysSection) {
  // Main haulage between M90 and M160 (arch 4.8 m wide, walls 1.5 m: 1.6 m up is just above
  // the springing line), and crosscut-90 half way between M90 and R90 (rectangle 4.0 m).
  const double arch = 2.0 * std::sqrt(2.4 * 2.4 - 0.1 * 0.1);
  EXPECT_NEAR(roadwayWidthAt(*survey_, map::Vec3(125.0, 0.0, -6.1 + 1.6)), arch, 1e-6);
  EXPECT_NEAR(roadwayWidthAt(*survey_, map::Vec3(90.0, 20.0, -4.04 + 1.6)), 4.0, 1e-9);
  EXPECT_EQ(roadwayWidthAt(map::SurveyNetwork(), map::Vec3::Zero()), 0.0);
}

}  // namespace
}  // namespace adit::sim

namespace adit::sim {
namespace {

// A map without a survey (the bundled district as an octree): starts and goals are drawn on the
// passages of its free-space roadway graph, with the robot's room, the same for the same seed.
// A real rib bulges at the floor where the field at the drawn height (1.6 m) sees room: a bench
// 0.4 m high and 1.0 m deep along the south rib of a 4.5 m roadway. A tracked robot's goals moved
// toward that rib stand where its body fits on the floor at some heading, its starts where it can
// turn on the spot; every scenario passes the run's own checks of its ends (before, a goal whose
// body overlapped the bench ended the run as an error).
TEST(BatchGroundRobot, GoalsNearABulgingRibLeaveTheBodyRoom) {
  const map::SurveyNetwork net = test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), 60.0, 0.2);
  map::OccupancyMap map = test::voxelizeOrFail(net);
  std::vector<map::Vec3> bench;
  for (double x = 0.1; x < 60.0; x += 0.2)
    for (double y = -2.15; y < -1.3; y += 0.2)
      for (double z = 0.1; z < 0.5; z += 0.2) bench.emplace_back(x, y, z);
  ASSERT_TRUE(map.setVoxels(bench, map::VoxelState::kOccupied).ok());
  StatusOr<map::DistanceField> field = map::DistanceField::build(map);
  ASSERT_TRUE(field.ok());
  StatusOr<Environment> env = Environment::borrow(map, *field);
  ASSERT_TRUE(env.ok()) << env.status().toString();
  Scenario base;
  base.name = "bench";
  base.file = "generated";
  base.params = local::LocalParams::preset(local::Method::kTian2016);
  base.start = map::Vec3(5, 0, 1.5);
  base.goal = map::Vec3(50, 0, 1.5);
  base.expected_path.points = {base.start, base.goal};
  BatchParams p;
  p.seed = 11;
  p.min_separation_m = 10.0;
  p.max_separation_m = 50.0;
  p.max_moving_obstacles = 0;
  p.roof_fall_probability = 0.0;
  p.near_rock_goal_share = 1.0;
  p.robot_json = "{\"mode\": \"ground\", \"drive\": \"skid\", \"footprint\": \"box:1.0,0.7\", \"height\": 0.6}";
  const BatchRoadways roadways = BatchRoadways::fromSurvey(net);
  int south = 0;
  for (int index = 0; index < 24; ++index) {
    StatusOr<Scenario> sc = makeBatchScenario(base, roadways, *env, p, index);
    ASSERT_TRUE(sc.ok()) << sc.status().toString();
    StatusOr<Scenario> placed = placeOnFloor(*sc, *env);
    ASSERT_TRUE(placed.ok()) << placed.status().toString();
    const Status ends = checkRunEnds(*placed, *env);
    EXPECT_TRUE(ends.ok()) << "scenario " << index << ": " << ends.message();
    EXPECT_GT(bodyFit(*placed, *env, placed->goal).most_m, 0.0) << index;
    EXPECT_GT(bodyFit(*placed, *env, placed->start).least_m, 0.0) << index;
    south += sc->goal.y() < -0.5;
  }
  EXPECT_GE(south, 4) << "no goal was moved toward the bench";
}

TEST(BatchOnAnyMap, StartsAndGoalsComeFromTheFreeSpaceGraph) {
  const std::string bt = std::string(ADIT_MAPS_DIR) + "/district.bt";
  StatusOr<sim::Scenario> sc = sim::parseScenario(
      "map: " + bt +
          "\nstart: [0, 0, 0]\ngoal: [1, 0, 0]\nexpected_path: plan\n"
          "robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 8}\nmethod: tian2016\n"
          "params: {rho0_m: 1.0}\ndt: 0.1\n",
      "batch_any_map");
  ASSERT_TRUE(sc.ok()) << sc.status().toString();
  StatusOr<sim::Environment> env = sim::Environment::load(*sc);
  ASSERT_TRUE(env.ok()) << env.status().toString();
  StatusOr<BatchRoadways> roadways = BatchRoadways::fromFreeSpace(*env->map(), *env->field(), 0.8);
  ASSERT_TRUE(roadways.ok()) << roadways.status().toString();
  EXPECT_EQ(roadways->source, "free_space");
  double length = 0;
  for (const map::Polyline& a : roadways->axes) length += a.length();
  EXPECT_GT(length, 1500.0);  // most of the district's 2.6 km of roadway
  BatchParams p;
  p.seed = 5;
  for (int index = 0; index < 8; ++index) {
    StatusOr<sim::Scenario> a = makeBatchScenario(*sc, *roadways, *env, p, index);
    StatusOr<sim::Scenario> b = makeBatchScenario(*sc, *roadways, *env, p, index);
    ASSERT_TRUE(a.ok()) << a.status().toString();
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(a->start, b->start);
    EXPECT_EQ(a->goal, b->goal);
    EXPECT_GT(env->field()->distance(a->start), 0.8);
    EXPECT_GT(env->field()->distance(a->goal), 0.8);
    EXPECT_GT(roadways->widthAt(a->start), 2.0);
  }
}

}  // namespace
}  // namespace adit::sim
