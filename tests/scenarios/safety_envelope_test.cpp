// SPDX-License-Identifier: BSD-3-Clause
// Issue 16: the safety envelope (EnvelopeParams). Every model, driven at full speed at a rib (a
// junction turn into a narrower branch), at a corner (the T into a cross-cut) and at a mover
// closing head-on, never ends `collision`: it may reach the goal, say `stuck`, or be run into by
// a mover it was not closing on (`hit_by_mover`), never drive into rock or a mover itself. The
// robot is fast for its brakes (1.5 m/s at 0.5 m/s^2: 2.25 m to stop, more than most models'
// repulsion range), so the field alone overshoots; the same runs with the envelope off are
// printed beside. In the papers' U trap every model ends `stuck` or `arrived`.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/sim/simulator.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is the local planner's.
using namespace adit::sim;

constexpr double kRadius = 0.3, kVMax = 1.5, kAMax = 0.5;

const Method kMethods[] = {Method::kClassic, Method::kTian2016, Method::kWang2014,
                           Method::kVff,     Method::kCvff,     Method::kUuv};

struct World {
  std::unique_ptr<map::OccupancyMap> map;
  std::unique_ptr<map::DistanceField> field;
  std::optional<Environment> env;
};

// The L of a 4 m arch main (A-D-B along x) and a 3 m gate branch north at B, with a 3 m
// cross-cut south at D: a turn into a narrower roadway, and a T.
World& junction() {
  static World* w = [] {
    auto* x = new World;
    x->map = std::make_unique<map::OccupancyMap>(test::voxelizeOrFail(test::junctionNetwork(0.2)));
    StatusOr<map::DistanceField> f = map::DistanceField::build(*x->map);
    EXPECT_TRUE(f.ok()) << f.status().message();
    x->field = std::make_unique<map::DistanceField>(std::move(*f));
    StatusOr<Environment> e = Environment::borrow(*x->map, *x->field);
    EXPECT_TRUE(e.ok()) << e.status().message();
    x->env.emplace(std::move(*e));
    return x;
  }();
  return *w;
}

struct Case {
  const char* name;
  std::vector<Vec3> path;
  bool mover = false;
};

std::vector<Case> cases() {
  return {
      {"rib: the turn at B into the 3 m branch", {Vec3(1.0, 0, 1.3), Vec3(14.0, 0, 1.5), Vec3(14.0, 8.0, 1.7)}},
      {"corner: the T at D into the cross-cut", {Vec3(1.0, 0, 1.3), Vec3(6.0, 0, 1.3), Vec3(6.0, -6.5, 1.2)}},
      {"mover: a 0.5 m ball closing head-on at 0.8 m/s", {Vec3(1.0, 0, 1.3), Vec3(13.0, 0, 1.5)}, true},
  };
}

Scenario scenario(const Case& k, Method m, bool envelope) {
  Scenario s;
  s.name = std::string(k.name) + "/" + methodName(m) + (envelope ? "" : "/no-envelope");
  s.file = s.name;
  s.start = k.path.front();
  s.goal = k.path.back();
  s.expected_path.points = k.path;
  s.params = LocalParams::preset(m);
  s.params.robot = {kRadius, kVMax, kAMax};
  s.params.envelope.enabled = envelope;
  s.params.envelope.sight_switch = envelope;
  if (k.mover) {
    NamedObstacle o;
    o.name = "machine";
    o.obstacle.shape = map::RobotShape::sphere(0.5);
    o.obstacle.position = Vec3(13.0, 0.0, 1.5);
    o.obstacle.velocity = Vec3(-0.8, 0.0, 0.0);
    s.moving_obstacles.push_back(o);
  }
  s.dt_s = 0.1;
  s.t_max_s = 60.0;
  return s;
}

TEST(SafetyEnvelope, NoModelDrivesIntoARibACornerOrAMoverAtFullSpeed) {
  int collisions_without = 0;
  for (const Case& k : cases()) {
    std::printf("%s\n", k.name);
    for (Method m : kMethods) {
      for (bool envelope : {true, false}) {
        const Scenario s = scenario(k, m, envelope);
        StatusOr<SimulationResult> r = simulate(s, *junction().env);
        ASSERT_TRUE(r.ok()) << r.status().message();
        std::printf("    %-9s %-11s %-12s t=%5.1f s, min clearance %6.3f m, %2d periods in contact, %s\n",
                    methodName(m), envelope ? "envelope" : "no envelope", outcomeName(r->outcome),
                    r->arrived() ? r->arrival_time_s : r->steps * s.dt_s, r->min_clearance_m, r->collisions,
                    r->message.c_str());
        if (!envelope) {
          collisions_without += r->outcome == Outcome::kCollision;
          continue;
        }
        EXPECT_NE(r->outcome, Outcome::kCollision) << s.name << ": " << r->message;
        if (!k.mover) {
          EXPECT_EQ(r->collisions, 0) << s.name;
        }
      }
    }
  }
  // The runs are deterministic: without the envelope some of them do collide, which is what
  // the envelope is for (a count, not a property of the models).
  std::printf("without the envelope: %d collisions\n", collisions_without);
  EXPECT_GE(collisions_without, 1);
}

TEST(SafetyEnvelope, EveryModelInTheUTrapEndsStuckOrArrivedNeverCollision) {
  StatusOr<Scenario> base = loadScenario(std::string(ADIT_MAPS_DIR) + "/scenarios/wang2014_u_trap_classic.yaml");
  ASSERT_TRUE(base.ok()) << base.status().message();
  for (Method m : kMethods) {
    for (bool paper : {false, true}) {
      Scenario s = *base;
      const RobotLimits robot = s.params.robot;
      s.params = paper ? LocalParams::paper(m) : LocalParams::preset(m);
      s.params.robot = robot;
      StatusOr<Environment> env = Environment::load(s);
      ASSERT_TRUE(env.ok()) << env.status().message();
      StatusOr<SimulationResult> r = simulate(s, *env);
      ASSERT_TRUE(r.ok()) << r.status().message();
      std::printf("U trap %-9s %-7s %-9s t=%5.1f s, min clearance %.3f m, %d escapes %s\n", methodName(m),
                  paper ? "paper" : "default", outcomeName(r->outcome), r->steps * s.dt_s, r->min_clearance_m,
                  r->escapes, r->message.c_str());
      EXPECT_TRUE(r->outcome == Outcome::kArrived || r->outcome == Outcome::kStuck)
          << methodName(m) << (paper ? " paper" : " default") << ": " << outcomeName(r->outcome) << " " << r->message;
      EXPECT_EQ(r->collisions, 0) << methodName(m);
    }
  }
}

}  // namespace
}  // namespace adit::local
