// SPDX-License-Identifier: BSD-3-Clause
// The scenario loader: the schema, defaults, and errors that name the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <unistd.h>

#include "adit/sim/scenario.hpp"
#include "adit/sim/simulator.hpp"

namespace adit::sim {
namespace {

const char* kGood = R"(start: [0, 0, 0]
goal: [14, 14, 0]
expected_path: [[0,0,0], [4.9,5,0], [10.8,6.2,0], [14,14,0]]
robot: {radius: 0.3, v_max: 1.0, a_max: 0.5}
static_obstacles:  [{center: [9, 11.5, 0], radius: 0.5}]
moving_obstacles:  [{start: [4, 8, 0], velocity: [0.25, -0.35, 0], acceleration: [0.036, 0.16, 0], radius: 0.3}]
method: tian2016
params: {k_l: 0.2, window_s: 5}
dt: 0.1
t_max: 300
seed: 1
)";

TEST(Scenario, ParsesTheIssueExample) {
  StatusOr<Scenario> s = parseScenario(kGood, "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->params.method, local::Method::kTian2016);
  EXPECT_EQ(s->expected_path.size(), 4u);
  EXPECT_EQ(s->params.tian2016.k_l, 0.2);
  EXPECT_EQ(s->params.monitor.window_s, 5.0);
  ASSERT_EQ(s->moving_obstacles.size(), 1u);
  EXPECT_EQ(s->moving_obstacles[0].obstacle.acceleration, Vec3(0.036, 0.16, 0));
  EXPECT_EQ(s->name, "good");
}

// A relative `map:` means the file beside the scenario, whatever the working directory holds; the
// working directory only when the scenario's folder has no such file.
TEST(Scenario, ARelativeMapIsTheOneBesideTheScenario) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("adit_scenario_map_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "scenarios");
  std::ofstream(dir / "scenarios" / "m.yaml") << "beside\n";
  std::ofstream(dir / "m.yaml") << "in the working directory\n";
  std::ofstream(dir / "only_here.yaml") << "only in the working directory\n";
  const fs::path cwd = fs::current_path();
  fs::current_path(dir);
  const std::string file = (dir / "scenarios" / "s.yaml").string();
  StatusOr<Scenario> beside = parseScenario(std::string(kGood) + "map: m.yaml\n", file);
  StatusOr<Scenario> fallback = parseScenario(std::string(kGood) + "map: only_here.yaml\n", file);
  StatusOr<Scenario> missing = parseScenario(std::string(kGood) + "map: nowhere.yaml\n", file);
  fs::current_path(cwd);
  ASSERT_TRUE(beside.ok()) << beside.status().message();
  ASSERT_TRUE(beside->map_path);
  EXPECT_EQ(fs::path(*beside->map_path), dir / "scenarios" / "m.yaml");
  ASSERT_TRUE(fallback.ok()) << fallback.status().message();
  ASSERT_TRUE(fallback->map_path);
  EXPECT_EQ(fs::path(*fallback->map_path), fs::path("only_here.yaml"));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("no such file 'nowhere.yaml' (relative to the scenario, or to the working directory)"),
            std::string::npos)
      << missing.status().message();
  fs::remove_all(dir);
}

TEST(Scenario, ASurveyMapIsNamedAsSuchNotParsedAsAScenario) {
  const StatusOr<Scenario> s = loadScenario(std::string(ADIT_MAPS_DIR) + "/sealed_roadway_map.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("sealed_roadway_map.yaml: this is a survey map, not a scenario"), std::string::npos)
      << s.status().message();
  EXPECT_NE(s.status().message().find("adit plan --map"), std::string::npos);
}

void expectError(const std::string& text, const std::string& needle) {
  StatusOr<Scenario> s = parseScenario(text, "bad.yaml");
  ASSERT_FALSE(s.ok()) << "accepted: " << text;
  EXPECT_NE(s.status().message().find(needle), std::string::npos) << s.status().message();
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const std::size_t i = s.find(from);
  EXPECT_NE(i, std::string::npos) << from;
  return s.replace(i, from.size(), to);
}

TEST(Scenario, ErrorsNameTheField) {
  expectError(replace(kGood, "method: tian2016", "method: khatib"), "bad.yaml:7:9: method: unknown method 'khatib'");
  expectError(replace(kGood, "radius: 0.3, v_max", "radius: -0.3, v_max"), "robot.radius: must be > 0");
  expectError(replace(kGood, "goal: [14, 14, 0]", "goal: [14, nan, 0]"), "goal[1]: 'nan' is not finite");
  expectError(replace(kGood, "seed: 1", "seed: 1\nspeed: 3"), "speed: unknown field");
  expectError(replace(kGood, "k_l: 0.2", "k_x: 0.2"), "params.k_x: unknown field for method tian2016");
  expectError(replace(kGood, "start: [0, 0, 0]", "start: [9, 11.2, 0]"), "start: the robot overlaps static_obstacles[0]");
  expectError(replace(kGood, "[14,14,0]]", "[14,13,0]]"), "expected_path: must end at the goal");
  expectError(replace(kGood, "radius: 0.3}]", "radius: 0.3, colour: red}]"), "moving_obstacles[0].colour: unknown field");
  expectError("start: [0, 0\n", "bad.yaml:");
  expectError(std::string(kGood) + "map: /nonexistent.bt\n", "map: no such file");
}

// Numbers a simulation cannot hold are refused here, naming the field (they used to surface as
// "internal: non-finite force", exit 1); a key given twice is refused (yaml-cpp keeps the first and
// would silently ignore the second); a seed is taken exactly, all 64 bits, never wrapped.
TEST(Scenario, OutOfRangeNumbersDuplicateKeysAndSeedsAreRefusedByName) {
  expectError(replace(kGood, "start: [0, 0, 0]", "start: [1e308, 0, 0]"), "start[0]: '1e308' is out of range");
  expectError(replace(kGood, "start: [0, 0, 0]", "start: [0, -2e7, 0]"), "start[1]: must be in [-1e+07, 1e+07] m");
  expectError(replace(kGood, "v_max: 1.0", "v_max: 1e308"), "robot.v_max: '1e308' is out of range");
  expectError(replace(kGood, "v_max: 1.0", "v_max: 500"), "robot.v_max: must be in [0, 100] m/s");
  expectError(replace(kGood, "[4.9,5,0]", "[4.9,1e308,0]"), "expected_path[1][1]: '1e308' is out of range");
  expectError(replace(kGood, "k_l: 0.2", "k_l: 1e300"), "params.k_l: '1e300' is out of range");
  expectError(std::string(kGood) + "goal: [1, 1, 0]\n", "goal: given twice");
  expectError(std::string(kGood) + "method: classic\n", "method: given twice");
  expectError(replace(kGood, "radius: 0.3, v_max", "radius: 0.3, radius: 0.4, v_max"), "robot.radius: given twice");
  expectError(replace(kGood, "k_l: 0.2", "k_l: 0.2, k_l: 0.3"), "params.k_l: given twice");
  expectError(replace(kGood, "seed: 1", "seed: 18446744073709551616"), "seed: '18446744073709551616' is larger than");
  expectError(replace(kGood, "seed: 1", "seed: -1"), "seed: must be an integer 0..18446744073709551615");
  expectError(replace(kGood, "seed: 1", "seed: 1.5"), "seed: must be an integer");
  StatusOr<Scenario> big = parseScenario(replace(kGood, "seed: 1", "seed: 18446744073709551615"), "big.yaml");
  ASSERT_TRUE(big.ok()) << big.status().message();
  EXPECT_EQ(big->seed, std::numeric_limits<std::uint64_t>::max());
  big = parseScenario(replace(kGood, "seed: 1", "seed: 9007199254740993"), "big.yaml");  // 2^53 + 1: no double holds it
  ASSERT_TRUE(big.ok()) << big.status().message();
  EXPECT_EQ(big->seed, 9007199254740993ull);
}

TEST(Scenario, SubgoalsKeyDefaultsToNoneAndParsesTheModes) {
  StatusOr<Scenario> s = parseScenario(kGood, "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->subgoal_mode, SubgoalMode::kNone);
  EXPECT_EQ(s->subgoal_period_s, 1.0);
  s = parseScenario(std::string(kGood) + "subgoals: ga_trust_region\nsubgoal_period: 0.5\n", "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->subgoal_mode, SubgoalMode::kGaTrustRegion);
  EXPECT_EQ(s->subgoal_period_s, 0.5);
  EXPECT_STREQ(subgoalModeName(s->subgoal_mode), "ga_trust_region");
  s = parseScenario(std::string(kGood) + "subgoals: none\n", "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->subgoal_mode, SubgoalMode::kNone);
}

// `preset: paper` turns the terminal phase off (the papers' fields as published); the default
// keeps it on; `params` may still set its fields by their visit() names, and bad values are named.
TEST(Scenario, PresetPaperTurnsTheTerminalPhaseOffAndParamsNameItsFields) {
  StatusOr<Scenario> s = parseScenario(kGood, "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->preset, ParamsPreset::kDefault);
  EXPECT_TRUE(s->params.terminal.enabled);
  EXPECT_TRUE(s->params.envelope.enabled);
  s = parseScenario(std::string(kGood) + "preset: paper\n", "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->preset, ParamsPreset::kPaper);
  EXPECT_FALSE(s->params.terminal.enabled);
  EXPECT_FALSE(s->params.envelope.enabled);
  EXPECT_FALSE(s->params.envelope.sight_switch);
  EXPECT_STREQ(paramsPresetName(s->preset), "paper");
  for (const char* name : {"tian2016_straight", "tian2016_polyline", "tian2016_polyline_subgoals", "wang2014_u_trap_classic",
                           "wang2014_u_trap_wang2014", "guo2022_static_vff", "guo2022_static_cvff", "guo2022_dynamic",
                           "uuv_3d"}) {
    StatusOr<Scenario> paper = loadScenario(std::string(ADIT_MAPS_DIR) + "/scenarios/" + name + ".yaml");
    ASSERT_TRUE(paper.ok()) << paper.status().message();
    EXPECT_EQ(paper->preset, ParamsPreset::kPaper) << name << ": a paper reproduction runs the paper's field";
  }
  StatusOr<Scenario> t = parseScenario(
      replace(std::string(kGood) + "preset: paper\n", "params: {k_l: 0.2, window_s: 5}",
              "params: {terminal: true, terminal_range_m: 3, terminal_n: 1, terminal_seek: false}"),
      "good.yaml");
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_TRUE(t->params.terminal.enabled);
  EXPECT_EQ(t->params.terminal.range_m, 3.0);
  EXPECT_EQ(t->params.terminal.n, 1.0);
  EXPECT_FALSE(t->params.terminal.seek);
  StatusOr<Scenario> e = parseScenario(
      replace(kGood, "params: {k_l: 0.2, window_s: 5}", "params: {envelope: false, envelope_keep_m: 0.1, sight_switch: false}"),
      "good.yaml");
  ASSERT_TRUE(e.ok()) << e.status().message();
  EXPECT_FALSE(e->params.envelope.enabled);
  EXPECT_EQ(e->params.envelope.keep_m, 0.1);
  EXPECT_FALSE(e->params.envelope.sight_switch);
  expectError(replace(kGood, "params: {k_l: 0.2, window_s: 5}", "params: {envelope_keep_m: -1}"),
              "EnvelopeParams::keep_m = -1");
  expectError(std::string(kGood) + "preset: published\n", "preset: unknown preset 'published' (default, paper)");
  expectError(replace(kGood, "params: {k_l: 0.2, window_s: 5}", "params: {terminal_range_m: 0}"),
              "TerminalParams::range_m = 0");
}

TEST(Scenario, SubgoalErrorsNameTheField) {
  expectError(std::string(kGood) + "subgoals: genetic\n",
              "bad.yaml:12:11: subgoals: unknown sub-goal mode 'genetic' (none, ga_trust_region)");
  expectError(std::string(kGood) + "subgoals: [ga_trust_region]\n", "subgoals: must be none or ga_trust_region");
  expectError(std::string(kGood) + "subgoal_period: 0\n", "subgoal_period: must be > 0");
  expectError(std::string(kGood) + "subgoal_period: 0.25\n", "bad.yaml:12:17: subgoal_period: must be a multiple of dt = 0.1 (got 0.25)");
  expectError(std::string(kGood) + "subgoal_period: 0.05\n", "subgoal_period: must be a multiple of dt");
  // Built in code rather than loaded: validate() says the same.
  StatusOr<Scenario> s = parseScenario(kGood, "good.yaml");
  ASSERT_TRUE(s.ok());
  s->subgoal_period_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(s->validate().message().find("subgoal_period"), std::string::npos);
}

// sim::simulate() has no selector of its own (it lives in adit::fusion): it says so instead
// of silently steering at the break points.
TEST(Scenario, SimulateRefusesSubgoalsWithoutASelector) {
  StatusOr<Scenario> s = parseScenario(std::string(kGood) + "subgoals: ga_trust_region\n", "good.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  StatusOr<SimulationResult> r = simulate(*s, Environment::openSpace());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("subgoals: ga_trust_region needs the selector"), std::string::npos)
      << r.status().message();
}

TEST(Scenario, MissingFileIsNamed) {
  StatusOr<Scenario> s = loadScenario("/nonexistent/scenario.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("/nonexistent/scenario.yaml"), std::string::npos);
}

}  // namespace
}  // namespace adit::sim

namespace adit::sim {
namespace {

// Timeouts and stuck runs sorted by what they would need: the time budget (the route given last
// could not be driven in the time left even at v_max), the field near the goal (ended within the
// terminal range), or the way along the route.
TEST(EndCause, SortsTimeoutsAndStuckRuns) {
  Scenario sc;
  sc.t_max_s = 100.0;
  sc.params.robot.v_max_mps = 1.0;
  sc.params.terminal.range_m = 4.0;
  EXPECT_EQ(endCause(sc, Outcome::kTimeout, 80.0, 0.0, 150.0), EndCause::kRouteOutlastsTime);
  EXPECT_EQ(endCause(sc, Outcome::kTimeout, 30.0, 60.0, 50.0), EndCause::kRouteOutlastsTime);  // replanned late
  EXPECT_EQ(endCause(sc, Outcome::kTimeout, 20.0, 10.0, 50.0), EndCause::kEnRoute);
  EXPECT_EQ(endCause(sc, Outcome::kTimeout, 3.0, 10.0, 50.0), EndCause::kShortOfGoal);
  // A stuck run never blames the time, however long its route.
  EXPECT_EQ(endCause(sc, Outcome::kStuck, 3.0, 0.0, 500.0), EndCause::kShortOfGoal);
  EXPECT_EQ(endCause(sc, Outcome::kStuck, 10.0, 0.0, 500.0), EndCause::kEnRoute);
  for (Outcome o : {Outcome::kArrived, Outcome::kCollision, Outcome::kNoRoute, Outcome::kHitByFall, Outcome::kHitByMover})
    EXPECT_EQ(endCause(sc, o, 50.0, 0.0, 500.0), EndCause::kNone) << outcomeName(o);
  for (EndCause c : {EndCause::kNone, EndCause::kRouteOutlastsTime, EndCause::kShortOfGoal, EndCause::kEnRoute})
    EXPECT_EQ(endCauseFromName(endCauseName(c)), c);
  EXPECT_FALSE(endCauseFromName("lost").has_value());
}

}  // namespace
}  // namespace adit::sim
