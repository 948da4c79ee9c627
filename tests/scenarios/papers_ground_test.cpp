// SPDX-License-Identifier: BSD-3-Clause
// The papers' set-ups whose robots are ground vehicles (Tian 2016's rescue robot, Wang 2014's
// mobile robot in the U trap, Guo 2022's inspection robot on the VFF grid), run with that robot
// as a differential-drive ground vehicle: the same disc as its footprint, v_max and a_max as the
// paper's, yaw rate within 1 rad/s and 2 rad/s^2 (the defaults), `preset: paper` kept. Beside
// each, the file as it is (the free-flying disc of the papers' plots). The papers' outcomes are
// asserted where they are the papers' (arrival, the classic field stalling in the U trap, no
// contact); times and lengths are printed for docs/papers.md, not asserted: a robot that must turn
// before it moves is slower, by how much is what the table shows. (The sub-goal variant of Tian's
// polyline runs through the navigator: `adit simulate` on the file with the robot changed.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "adit/local/simulator.hpp"

namespace adit::local {
namespace {

const std::string kDir = std::string(ADIT_MAPS_DIR) + "/scenarios/";

Scenario load(const std::string& name) {
  StatusOr<Scenario> s = loadScenario(kDir + name);
  EXPECT_TRUE(s.ok()) << s.status().message();
  return s.ok() ? *s : Scenario{};
}

// The paper's robot as a differential-drive ground vehicle with the same disc.
Scenario asGroundVehicle(Scenario sc) {
  RobotLimits& r = sc.params.robot;
  r.mode = RobotMode::kGround;
  r.drive = DriveType::kDifferential;
  r.footprint.box = false;
  r.footprint.radius_m = r.radius_m;
  r.height_m = std::max(0.3, 2.0 * r.radius_m);
  sc.name += " (ground)";
  return sc;
}

SimulationResult run(const Scenario& sc) {
  StatusOr<Environment> env = Environment::load(sc);
  EXPECT_TRUE(env.ok()) << env.status().message();
  if (!env.ok()) return {};
  StatusOr<SimulationResult> r = simulate(sc, *env);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? *r : SimulationResult{};
}

void print(const char* file, const SimulationResult& fly, const SimulationResult& ground) {
  auto text = [](const SimulationResult& x) {
    char buf[160];
    if (x.outcome == Outcome::kArrived)
      std::snprintf(buf, sizeof buf, "arrived %.1f s, %.2f m, %d steps, %.2f m", x.arrival_time_s, x.path_length_m,
                    x.steps, x.min_clearance_m);
    else
      std::snprintf(buf, sizeof buf, "%s, %.2f m, %d steps, %.2f m", outcomeName(x.outcome), x.path_length_m, x.steps,
                    x.min_clearance_m);
    return std::string(buf);
  };
  std::printf("| %s | %s | %s |\n", file, text(fly).c_str(), text(ground).c_str());
}

struct Case {
  const char* file;
  Outcome expected;  // the paper's outcome, which the ground vehicle must reproduce too
};

class PapersAsGroundVehicles : public ::testing::TestWithParam<Case> {};

TEST_P(PapersAsGroundVehicles, ReproduceThePapersOutcomeWithoutContact) {
  const Case c = GetParam();
  const Scenario fly_sc = load(c.file);
  ASSERT_FALSE(fly_sc.params.terminal.enabled) << c.file << " should say preset: paper";
  const Scenario ground_sc = asGroundVehicle(fly_sc);
  const SimulationResult fly = run(fly_sc), ground = run(ground_sc);
  print(c.file, fly, ground);
  EXPECT_EQ(ground.outcome, c.expected) << ground.message;
  EXPECT_EQ(ground.collisions, 0);
  EXPECT_GT(ground.min_clearance_m, 0.0);
  // On the floor all the way: open space has a flat floor half the body under the centre.
  for (const TrajectorySample& s : ground.trajectory)
    ASSERT_NEAR(s.position.z(), ground.trajectory.front().position.z(), 1e-9) << "t = " << s.t_s;
  if (c.expected == Outcome::kArrived) {
    EXPECT_LE(ground.final_goal_distance_m, ground.arrival_tolerance_m);
    // Turning before it moves costs time, not the way: within half again the flying path.
    EXPECT_LT(ground.path_length_m, 1.5 * fly.path_length_m);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Papers, PapersAsGroundVehicles,
    ::testing::Values(Case{"tian2016_straight.yaml", Outcome::kArrived}, Case{"tian2016_polyline.yaml", Outcome::kArrived},
                      Case{"wang2014_u_trap_classic.yaml", Outcome::kStuck},
                      Case{"wang2014_u_trap_wang2014.yaml", Outcome::kArrived},
                      Case{"guo2022_static_vff.yaml", Outcome::kArrived},
                      Case{"guo2022_static_cvff.yaml", Outcome::kArrived},
                      Case{"guo2022_dynamic.yaml", Outcome::kArrived}),
    [](const ::testing::TestParamInfo<Case>& param) {
      std::string n = param.param.file;
      n = n.substr(0, n.find('.'));
      return n;
    });

}  // namespace
}  // namespace adit::local
