// SPDX-License-Identifier: BSD-3-Clause
// Issue 20: every goal the robot fits at is reached. Goals placed where the robot's centre is its
// radius + the planner's safety margin + 0.1 m from rock (by the floor, by a rib, in a junction's
// corner, at a dead end's face) on generated roadways; every model, fly mode, the default
// parameters (terminal phase on). The bound on the time is 2 x the expected path's length / v_max.
// The same goals with the papers' fields as published (preset paper) are run and printed beside.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/local/simulator.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

constexpr double kRadius = 0.4;          // the flying sphere
constexpr double kSafetyMargin = 0.2;    // GlobalPlannerParams::safety_margin_m's default
constexpr double kBeyondMargin = 0.1;    // the issue: radius + margin + 0.1 m from rock
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

struct Case {
  std::string name;
  const Roadway* roadway;
  map::Polyline path;  // start ... goal
};

class TerminalPhase : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The held-out survey, shortened: a straight 5.7 deg incline, 4.5 x 3.5 m rectangle.
    constexpr double kLength = 30.0;
    const double rise = kLength * std::tan(5.7 * 3.14159265358979 / 180.0);
    incline_ = Roadway::build(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), kLength, 0.2, rise)).release();
    // An L (main A-D-B, branch B-C north) with a T (cross-cut D-E south).
    junction_ = Roadway::build(test::junctionNetwork(0.2)).release();
  }
  static void TearDownTestSuite() {
    delete incline_;
    delete junction_;
  }

  static std::vector<Case> cases() {
    const double c = kRadius + kSafetyMargin + kBeyondMargin;
    const double slope = std::tan(5.7 * 3.14159265358979 / 180.0);
    auto inclineAxis = [&](double x) { return Vec3(x, 0.0, slope * x + 1.75); };  // mid-height
    const Vec3 start = inclineAxis(3.0), near_end = inclineAxis(26.0);
    std::vector<Case> out;
    out.push_back({"floor", incline_, {{start, incline_->toward(near_end, -Vec3::UnitZ(), c)}}});
    out.push_back({"rib", incline_, {{start, incline_->toward(near_end, Vec3::UnitY(), c)}}});
    out.push_back({"dead_end_face", incline_, {{start, incline_->toward(near_end, Vec3::UnitX(), c)}}});
    // The L's outer corner at B (14, 0, floor 0.3): between the main's south rib and the east rib
    // of the branch, 1.5 m above the floor.
    const Vec3 j_start(2.0, 0.0, 1.6), bend(14.0, 0.0, 1.8);
    out.push_back({"junction_corner", junction_, {{j_start, bend, junction_->toward(bend, Vec3(1, -1, 0), c)}}});
    return out;
  }

  static Scenario scenario(const Case& k, Method m, bool paper) {
    Scenario s;
    s.name = k.name + "/" + methodName(m) + (paper ? "/paper" : "");
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

  static Roadway* incline_;
  static Roadway* junction_;
};
Roadway* TerminalPhase::incline_ = nullptr;
Roadway* TerminalPhase::junction_ = nullptr;

// Every model arrives at every near-rock goal without touching rock, in time; with the papers'
// fields (terminal phase off) at least one of them does not: the failure the phase is for. That
// count is asserted because the runs are deterministic (no random part), not as a property of
// the papers' models.
TEST_F(TerminalPhase, EveryModelReachesGoalsByTheFloorRibCornerAndFace) {
  int paper_short = 0;
  for (const Case& k : cases()) {
    const double goal_clearance = k.roadway->field->distance(k.path.points.back());
    std::printf("%s: goal (%.2f, %.2f, %.2f), centre %.2f m from rock, expected path %.2f m\n", k.name.c_str(),
                k.path.points.back().x(), k.path.points.back().y(), k.path.points.back().z(), goal_clearance,
                k.path.length());
    ASSERT_GE(goal_clearance, kRadius + kSafetyMargin + kBeyondMargin - 1e-9) << k.name;
    ASSERT_LT(goal_clearance, kRadius + kSafetyMargin + kBeyondMargin + 0.02) << k.name;
    const double bound = kTimeFactor * k.path.length() / kVMax;
    for (Method m : kMethods) {
      for (bool paper : {false, true}) {
        const Scenario s = scenario(k, m, paper);
        StatusOr<SimulationResult> r = simulate(s, *k.roadway->env);
        ASSERT_TRUE(r.ok()) << r.status().message();
        std::printf("    %-9s %-7s %-8s t=%6.1f s, path %6.2f m, final %.2f m from the goal, min clearance %.3f m, "
                    "%d collisions, %d escapes\n",
                    methodName(m), paper ? "paper" : "default", outcomeName(r->outcome), r->arrival_time_s,
                    r->path_length_m, r->final_goal_distance_m, r->min_clearance_m, r->collisions, r->escapes);
        if (paper) {
          paper_short += !r->arrived();
          continue;
        }
        EXPECT_EQ(r->outcome, Outcome::kArrived) << s.name << ": " << r->message;
        EXPECT_EQ(r->collisions, 0) << s.name;
        EXPECT_GT(r->min_clearance_m, 0.0) << s.name;
        if (r->arrived()) {
          EXPECT_LE(r->arrival_time_s, bound) << s.name;
        }
      }
    }
  }
  std::printf("with the papers' fields (preset paper): %d of %zu runs fall short\n", paper_short,
              cases().size() * std::size(kMethods));
  EXPECT_GE(paper_short, 1);
}

}  // namespace
}  // namespace adit::local
