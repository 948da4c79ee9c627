// SPDX-License-Identifier: BSD-3-Clause
// Issue 20: every goal the robot fits at is reached. Goals placed where the robot's centre is its
// radius + the planner's safety margin + 0.1 m from rock (by the floor, by a rib, in an L's and a
// T's corner, at a dead end's face straight ahead and round a T) on generated roadways; every
// model, fly mode, the default parameters (terminal phase on), one test per goal and model. The
// bound on the time is 2 x the expected path's length / v_max. The same goals with the papers'
// fields as published (preset paper) are run and printed beside. In ground mode the same goals
// (the floor's aside: a ground robot's every pose is on the floor) for the tracked rescue robot,
// its footprint's circumradius standing in for the radius.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/sim/simulator.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is the local planner's.
using namespace adit::sim;

constexpr double kRadius = 0.4;          // the flying sphere
constexpr double kSafetyMargin = 0.2;    // GlobalPlannerParams::safety_margin_m's default
constexpr double kBeyondMargin = 0.1;    // the issue: radius + margin + 0.1 m from rock
constexpr double kClearance = kRadius + kSafetyMargin + kBeyondMargin;
constexpr double kTimeFactor = 2.0;      // arrival within 2 x path length / v_max
constexpr double kVMax = 1.0, kAMax = 0.5;

const Method kMethods[] = {Method::kClassic, Method::kTian2016, Method::kWang2014,
                           Method::kVff,     Method::kCvff,     Method::kUuv};
// wang2014 and uuv arrive with their Ge-Cui factor bounded (goal_factor_cap_m, the default
// preset): unbounded (preset paper) wang2014 crawled at 0.04 m/s, 145-188 s for 23-26 m, and
// uuv touched the rib and the face.

// A map, its field and the simulator's environment over them, built once per roadway.
struct Roadway {
  std::unique_ptr<map::OccupancyMap> map;
  std::unique_ptr<map::DistanceField> field;
  std::optional<Environment> env;
  static std::unique_ptr<Roadway> build(const map::SurveyNetwork& net) {
    auto r = std::make_unique<Roadway>();
    r->map = std::make_unique<map::OccupancyMap>(test::voxelizeOrFail(net));
    StatusOr<map::DistanceField> f = map::DistanceField::build(*r->map);
    EXPECT_TRUE(f.ok()) << f.status().message();
    r->field = std::make_unique<map::DistanceField>(std::move(*f));
    StatusOr<Environment> e = Environment::borrow(*r->map, *r->field);
    EXPECT_TRUE(e.ok()) << e.status().message();
    r->env.emplace(std::move(*e));
    return r;
  }
  // From `from` along `dir` in 1 cm steps, the last point whose centre keeps `clearance` from rock.
  Vec3 toward(const Vec3& from, const Vec3& dir, double clearance) const {
    const Vec3 u = dir.normalized();
    Vec3 last = from;
    EXPECT_GE(field->distance(from), clearance);
    for (double s = 0.01; s < 20.0; s += 0.01) {
      const Vec3 p = from + s * u;
      if (!field->isFree(p) || field->distance(p) < clearance) break;
      last = p;
    }
    return last;
  }
};

// Built on first use and kept for the process: each CTest entry runs one goal and model.
const Roadway& incline() {
  // The held-out survey, shortened: a straight 5.7 deg incline, 4.5 x 3.5 m rectangle,
  // ending in a face.
  static const std::unique_ptr<Roadway> r = [] {
    constexpr double kLength = 30.0;
    const double rise = kLength * std::tan(5.7 * 3.14159265358979 / 180.0);
    return Roadway::build(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), kLength, 0.2, rise));
  }();
  return *r;
}
const Roadway& junction() {
  // An L (main A-D-B, branch B-C north) with a T (cross-cut D-E south, a dead end).
  static const std::unique_ptr<Roadway> r = Roadway::build(test::junctionNetwork(0.2));
  return *r;
}

struct Case {
  const Roadway* roadway;
  map::Polyline path;  // start ... goal
};

const char* const kCases[] = {"floor", "rib", "dead_end_face", "l_junction_corner", "t_junction_corner",
                              "crosscut_dead_end_face"};

Case caseNamed(const std::string& name, double clearance = kClearance) {
  const double slope = std::tan(5.7 * 3.14159265358979 / 180.0);
  auto inclineAxis = [&](double x) { return Vec3(x, 0.0, slope * x + 1.75); };  // mid-height
  const Vec3 start = inclineAxis(3.0), near_end = inclineAxis(26.0);
  const Roadway& in = incline();
  if (name == "floor") return {&in, {{start, in.toward(near_end, -Vec3::UnitZ(), clearance)}}};
  if (name == "rib") return {&in, {{start, in.toward(near_end, Vec3::UnitY(), clearance)}}};
  if (name == "dead_end_face") return {&in, {{start, in.toward(near_end, Vec3::UnitX(), clearance)}}};
  const Roadway& j = junction();
  // Main A (0,0) - D (6,0) - B (14,0), floors 0 to 0.3 m, an arch 4 m wide; the branch north
  // from B and the cross-cut south from D are 3 x 3 m rectangles.
  const Vec3 j_start(2.0, 0.0, 1.6), t_mouth(6.0, 0.0, 1.6), bend(14.0, 0.0, 1.8);
  // The L's outer (concave) corner at B: between the main's south rib and the branch's east rib.
  if (name == "l_junction_corner") return {&j, {{j_start, bend, j.toward(bend, Vec3(1, -1, 0), clearance)}}};
  // The T's corner at D: where the main's south rib turns into the cross-cut's east rib.
  if (name == "t_junction_corner")
    return {&j, {{j_start, t_mouth, j.toward(t_mouth, Vec3(1, -1, 0), clearance)}}};
  // The cross-cut's face 8 m south of D, reached round the T.
  if (name == "crosscut_dead_end_face") {
    const Vec3 in_crosscut(6.0, -6.0, 1.5);
    return {&j, {{j_start, t_mouth, in_crosscut, j.toward(in_crosscut, -Vec3::UnitY(), clearance)}}};
  }
  ADD_FAILURE() << "no case " << name;
  return {&in, {{start, near_end}}};
}

Scenario scenario(const std::string& name, const Case& k, Method m, bool paper) {
  Scenario s;
  s.name = name + "/" + methodName(m) + (paper ? "/paper" : "");
  s.file = s.name;
  s.start = k.path.points.front();
  s.goal = k.path.points.back();
  s.expected_path = k.path;
  s.preset = paper ? ParamsPreset::kPaper : ParamsPreset::kDefault;
  s.params = paper ? LocalParams::paper(m) : LocalParams::preset(m);
  s.params.robot = {kRadius, kVMax, kAMax};
  s.dt_s = 0.1;
  s.t_max_s = 200.0;
  return s;
}

// Runs one goal and model; prints the run; the goal's placement is checked first.
SimulationResult runCase(const std::string& name, Method m, bool paper) {
  const Case k = caseNamed(name);
  const Vec3& goal = k.path.points.back();
  const double goal_clearance = k.roadway->field->distance(goal);
  EXPECT_GE(goal_clearance, kClearance - 1e-9) << name;
  EXPECT_LT(goal_clearance, kClearance + 0.02) << name;
  const Scenario s = scenario(name, k, m, paper);
  StatusOr<SimulationResult> r = simulate(s, *k.roadway->env);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) return {};
  std::printf("%-22s %-9s %-7s goal (%.2f, %.2f, %.2f) %.2f m from rock, expected path %.2f m: %-9s t=%6.1f s, "
              "path %6.2f m, final %.2f m from the goal, min clearance %.3f m, %d collisions, %d escapes\n",
              name.c_str(), methodName(m), paper ? "paper" : "default", goal.x(), goal.y(), goal.z(), goal_clearance,
              k.path.length(), outcomeName(r->outcome), r->arrival_time_s, r->path_length_m, r->final_goal_distance_m,
              r->min_clearance_m, r->collisions, r->escapes);
  return std::move(*r);
}

class TerminalPhase : public ::testing::TestWithParam<std::tuple<const char*, Method>> {};

// The model arrives at the near-rock goal without touching rock, in time.
TEST_P(TerminalPhase, ArrivesWithoutCollisionInTime) {
  const auto [name, m] = GetParam();
  const Case k = caseNamed(name);
  const SimulationResult r = runCase(name, m, /*paper=*/false);
  EXPECT_EQ(r.outcome, Outcome::kArrived) << name << "/" << methodName(m) << ": " << r.message;
  EXPECT_EQ(r.collisions, 0);
  EXPECT_GT(r.min_clearance_m, 0.0);
  if (r.arrived()) {
    EXPECT_LE(r.arrival_time_s, kTimeFactor * k.path.length() / kVMax);
  }
}

INSTANTIATE_TEST_SUITE_P(EveryGoalAndModel, TerminalPhase,
                         ::testing::Combine(::testing::ValuesIn(kCases), ::testing::ValuesIn(kMethods)),
                         [](const ::testing::TestParamInfo<TerminalPhase::ParamType>& p) {
                           return std::string(std::get<0>(p.param)) + "_" + methodName(std::get<1>(p.param));
                         });

// With the papers' fields (terminal phase off) at least one run falls short: the failure the
// phase is for. That count is asserted because the runs are deterministic (no random part), not
// as a property of the papers' models.
TEST(TerminalPhasePaper, ThePapersFieldsFallShortOfSomeGoal) {
  int paper_short = 0, runs = 0;
  for (const char* name : kCases) {
    for (Method m : kMethods) {
      paper_short += !runCase(name, m, /*paper=*/true).arrived();
      ++runs;
    }
  }
  std::printf("with the papers' fields (preset paper): %d of %d runs fall short\n", paper_short, runs);
  EXPECT_GE(paper_short, 1);
}

}  // namespace
}  // namespace adit::local

namespace adit::local {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is the local planner's.
using namespace adit::sim;

// Ground mode: the tracked rescue robot (1.0 x 0.7 m box, 0.6 m high, skid steering) at the same
// goals, each placed its circumradius + margin + 0.1 m from the rib, corner or face at mid-height
// (the field's distance there is the horizontal one: floor and roof are farther), then set on the
// floor by the simulator.
const char* const kGroundCases[] = {"rib", "dead_end_face", "l_junction_corner", "t_junction_corner",
                                    "crosscut_dead_end_face"};

// With pursuit (the ground default) and with the model's field alone, which is what drives when
// the line ahead is not clear.
class TerminalPhaseGround : public ::testing::TestWithParam<std::tuple<const char*, Method, bool>> {};

TEST_P(TerminalPhaseGround, ArrivesWithoutCollisionInTime) {
  const auto [name, m, pursuit] = GetParam();
  const RobotLimits robot = RobotLimits::trackedRescue();
  const double clearance = robot.footprint.circumradius() + kSafetyMargin + kBeyondMargin;
  const Case k = caseNamed(name, clearance);
  const Vec3& goal = k.path.points.back();
  EXPECT_GE(k.roadway->field->distance(goal), clearance - 1e-9) << name;
  Scenario s = scenario(name, k, m, /*paper=*/false);
  s.name += "/ground";
  s.params.robot = robot;
  s.params.pursuit.enabled = pursuit;
  StatusOr<SimulationResult> r = simulate(s, *k.roadway->env);
  ASSERT_TRUE(r.ok()) << r.status().message();
  std::printf("%-22s %-9s ground, %-10s goal (%.2f, %.2f) expected path %.2f m: %-9s t=%6.1f s, path %6.2f m, final %.2f m "
              "from the goal, min clearance %.3f m, %d collisions\n",
              name, methodName(m), pursuit ? "pursuit" : "field only", goal.x(), goal.y(), k.path.length(),
              outcomeName(r->outcome), r->arrival_time_s,
              r->path_length_m, r->final_goal_distance_m, r->min_clearance_m, r->collisions);
  EXPECT_EQ(r->outcome, Outcome::kArrived) << name << "/" << methodName(m) << ": " << r->message;
  EXPECT_EQ(r->collisions, 0);
  EXPECT_GT(r->min_clearance_m, 0.0);
  // The time bound holds for the default (pursuit). The field alone arrives everywhere, but
  // tian2016's 2 m repulsion weaves across the 3 m cross-cut (yaw swinging +-0.7 rad about its
  // axis): 29.2 s for the 11.1 m to its face, 11.6 s for the 5.7 m to the T's corner.
  if (r->arrived() && pursuit) {
    EXPECT_LE(r->arrival_time_s, kTimeFactor * k.path.length() / robot.v_max_mps);
  }
}

INSTANTIATE_TEST_SUITE_P(EveryGoalAndModel, TerminalPhaseGround,
                         ::testing::Combine(::testing::ValuesIn(kGroundCases), ::testing::ValuesIn(kMethods),
                                            ::testing::Bool()),
                         [](const ::testing::TestParamInfo<TerminalPhaseGround::ParamType>& p) {
                           return std::string(std::get<0>(p.param)) + "_" + methodName(std::get<1>(p.param)) +
                                  (std::get<2>(p.param) ? "_pursuit" : "_field");
                         });

}  // namespace
}  // namespace adit::local
