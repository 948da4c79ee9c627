// SPDX-License-Identifier: BSD-3-Clause
// The papers' set-ups (maps/scenarios/) run end to end through the simulator. Each test names its
// tolerance and why; the simulator's referee, not the planner, decides collisions and arrival.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>

#include "adit/map/distance_field.hpp"
#include "adit/sim/simulator.hpp"

namespace adit::local {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is the local planner's.
using namespace adit::sim;

const std::string kDir = std::string(ADIT_MAPS_DIR) + "/scenarios/";

Scenario load(const std::string& name) {
  StatusOr<Scenario> s = loadScenario(kDir + name);
  EXPECT_TRUE(s.ok()) << s.status().message();
  return s.ok() ? *s : Scenario{};
}

SimulationResult run(const Scenario& sc) {
  StatusOr<Environment> env = Environment::load(sc);
  EXPECT_TRUE(env.ok()) << env.status().message();
  if (!env.ok()) return {};
  StatusOr<SimulationResult> r = simulate(sc, *env);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (!r.ok()) return {};
  const SimulationResult& x = *r;
  std::printf("[%s/%s] %s t=%.1f s, path %.2f m, min clearance %.3f m, %d collisions, %d steps, %d escapes\n",
              sc.name.c_str(), methodName(sc.params.method), outcomeName(x.outcome), x.arrival_time_s,
              x.path_length_m, x.min_clearance_m, x.collisions, x.steps, x.escapes);
  for (const ClosestApproach& c : x.closest)
    std::printf("    closest approach to %s: %.3f m at t = %.1f s\n", c.name.c_str(), c.distance_m, c.t_s);
  return x;
}

void expectCleanArrival(const SimulationResult& r) {
  EXPECT_EQ(r.outcome, Outcome::kArrived) << r.message;
  EXPECT_EQ(r.collisions, 0);
  EXPECT_GT(r.min_clearance_m, 0.0);
  EXPECT_LE(r.final_goal_distance_m, r.arrival_tolerance_m);
}

// Largest distance of the trajectory from the expected path.
double maxDeviation(const Scenario& sc, const SimulationResult& r) {
  double d = 0.0;
  for (const TrajectorySample& s : r.trajectory)
    d = std::max(d, (s.position - sc.expected_path.nearestPoint(s.position)).norm());
  return d;
}

// Tian 2016 straight path: arrives without collision and meets obstacle 5 where the paper does
// (tolerance: inside the repulsion range rho_0 = 2 m, within 2 s of the paper's t = 18 s; the
// scenario's comment gives the sign reading of its acceleration). The line field's job is to hold
// the robot on the expected path, so "worse without it" is measured as the largest deviation from
// the path (tolerance: strictly larger without). The paper's local minimum without the line field
// is not reproduced: the robot arrives either way, without the line field even a little sooner
// (printed, not asserted; see the README). At 1 m/s it passes the crossing of obstacle 5's track
// with the path about 5 s before obstacle 5 gets there, so obstacle 5 never stands between it and
// the goal; a point robot (radius 0.05) and the bare field (params prediction_horizon_s = 0,
// safety_horizon_s = 0) gave the same.
TEST(Scenarios, Tian2016StraightArrivesAndTheLineFieldHoldsThePath) {
  const Scenario sc = load("tian2016_straight.yaml");
  const SimulationResult with = run(sc);
  expectCleanArrival(with);
  ASSERT_EQ(with.closest.size(), 3u);
  const ClosestApproach& fifth = with.closest[2];
  EXPECT_EQ(fifth.name, "obstacle 5");
  EXPECT_LT(fifth.distance_m, sc.params.tian2016.rho0_m);
  EXPECT_NEAR(fifth.t_s, 18.0, 2.0);
  Scenario without = sc;
  without.params.tian2016.k_l = 0.0;
  const SimulationResult no_line = run(without);
  expectCleanArrival(no_line);
  const double dev_with = maxDeviation(sc, with), dev_without = maxDeviation(sc, no_line);
  std::printf("    max deviation from the expected path: %.3f m with the line field, %.3f m without\n", dev_with,
              dev_without);
  std::printf("    arrival %.1f s / path %.2f m with the line field, %.1f s / %.2f m without\n", with.arrival_time_s,
              with.path_length_m, no_line.arrival_time_s, no_line.path_length_m);
  EXPECT_LT(dev_with, dev_without);
}

// Tian 2016 polyline path through the paper's break points A and B: arrives without collision,
// and with the line field sooner and along a shorter path than without it (tolerance: strictly;
// the paper: 97 s against 161 s).
TEST(Scenarios, Tian2016PolylineTheLineFieldArrivesSooner) {
  const Scenario sc = load("tian2016_polyline.yaml");
  const SimulationResult with = run(sc);
  expectCleanArrival(with);
  Scenario without = sc;
  without.params.tian2016.k_l = 0.0;
  const SimulationResult no_line = run(without);
  expectCleanArrival(no_line);
  std::printf("    arrival %.1f s with the line field, %.1f s without (paper: 97 s, 161 s)\n", with.arrival_time_s,
              no_line.arrival_time_s);
  EXPECT_LT(with.arrival_time_s, no_line.arrival_time_s);
  EXPECT_LT(with.path_length_m, no_line.path_length_m);
}

// Wang 2014 U-trap: Khatib's APF has no escape and must say stuck (not timeout, not arrived);
// the improved model passes. Tolerance: outcome only.
TEST(Scenarios, Wang2014UTrapClassicStuckImprovedPasses) {
  const SimulationResult classic = run(load("wang2014_u_trap_classic.yaml"));
  EXPECT_EQ(classic.outcome, Outcome::kStuck);
  EXPECT_EQ(classic.collisions, 0);
  EXPECT_GT(classic.final_goal_distance_m, 1.0);
  EXPECT_TRUE(classic.escape_times_s.empty());  // the classic preset has no escapes
  const SimulationResult improved = run(load("wang2014_u_trap_wang2014.yaml"));
  expectCleanArrival(improved);
  // Each escape's start is kept (for the replay's timeline), inside the run.
  EXPECT_GE(improved.escape_times_s.size(), std::size_t(improved.escapes));
  for (double t : improved.escape_times_s) {
    EXPECT_GT(t, 0.0);
    EXPECT_LT(t, improved.arrival_time_s);
  }
}

// Guo 2022 static: CVFF needs fewer iterations (steps) than VFF, as in the paper's Tables 2-3
// (64 vs 75 at p0 = 0.5; 62 vs 74 at p0 = 1). Tolerance: strictly fewer. Its shorter trajectory
// (17.378 vs 19.175 dm; 19.036 vs 20.412 dm) is reproduced at p0 = 0.5 only (strictly shorter);
// at p0 = 1 CVFF's path is 0.8 % longer here (tolerance: within 2 %). The paper gives its layout
// only in a figure, and no other faithful reading gave both at both p0 on this layout:
// - eq. 15's kinematic step (direction F/|F| each iteration, no acceleration limit, step l0
//   whatever |F|: overrides dt = l0, robot.a_max = 20 or 100, params.full_speed_force = 0.001),
//   l0 = 0.1 and 0.25 grid units: fewer and shorter at p0 = 0.5, but at p0 = 1 CVFF 157 vs 156
//   and 66 vs 65 steps, longer; l0 = 0.5: both collide at p0 = 0.5; l0 = 1: CVFF worse at both;
// - a point robot (radius 0.01, d measured from the aircraft's coordinates as in eq. 5), with
//   either motion: at p0 = 1 CVFF again longer (15.40 vs 15.37 m; 15.22 vs 15.13 m).
// The paper's own length per iteration (0.26-0.31) is not constant, so its step is not eq. 15's
// fixed l0 either (see the README).
TEST(Scenarios, Guo2022StaticCvffFewerIterationsThanVff) {
  for (double p0 : {0.5, 1.0}) {
    Scenario vff = load("guo2022_static_vff.yaml"), cvff = load("guo2022_static_cvff.yaml");
    vff.params.vff.p0_m = cvff.params.vff.p0_m = p0;
    const SimulationResult a = run(vff), b = run(cvff);
    expectCleanArrival(a);
    expectCleanArrival(b);
    std::printf("    p0 = %.1f: VFF %d steps %.2f m, CVFF %d steps %.2f m\n", p0, a.steps, a.path_length_m, b.steps,
                b.path_length_m);
    EXPECT_LT(b.steps, a.steps);
    if (p0 < 1.0) EXPECT_LT(b.path_length_m, a.path_length_m);
    else EXPECT_LT(b.path_length_m, 1.02 * a.path_length_m);
  }
}

// Guo 2022 dynamic: no collision; the closest approaches are reported beside the paper's
// 5 dm and 8 dm (centre distances there; surface distances here).
TEST(Scenarios, Guo2022DynamicNoCollision) {
  const SimulationResult r = run(load("guo2022_dynamic.yaml"));
  expectCleanArrival(r);
  ASSERT_EQ(r.closest.size(), 2u);
  std::printf("    paper: 0.5 m at t = 12 s and 0.8 m at t = 31 s\n");
  for (const ClosestApproach& c : r.closest) EXPECT_GT(c.distance_m, 0.0);
}

// UUV 3-D: the sphere sits above the track, so the rotation direction sends the vehicle below
// it. Tolerance: every sample within 1 m of the sphere's x lies below the track (z < 0).
TEST(Scenarios, UuvPassesOnTheNearerSide) {
  const Scenario sc = load("uuv_3d.yaml");
  const SimulationResult r = run(sc);
  expectCleanArrival(r);
  int beside = 0;
  for (const TrajectorySample& s : r.trajectory) {
    if (std::abs(s.position.x() - 10.0) > 1.0) continue;
    ++beside;
    EXPECT_LT(s.position.z(), 0.0) << "t = " << s.t_s;
  }
  EXPECT_GT(beside, 0);
}

// The bundled district: along the main haulage roadway past an oncoming machine. Rock and the
// machine are checked by the referee (exact FCL distances). Tolerance: arrival, no collision.
TEST(Scenarios, DistrictRoadwayWithOncomingMachine) {
  const SimulationResult r = run(load("district_oncoming.yaml"));
  expectCleanArrival(r);
  ASSERT_EQ(r.closest.size(), 1u);
  EXPECT_GT(r.closest[0].distance_m, 0.0);
}

// A goal the robot cannot be at (its sphere would overlap the floor) is refused before the run
// with a message that says so, instead of ending stuck or timed out against the floor.
TEST(Scenarios, AGoalTheRobotDoesNotFitAtIsRefusedUpFront) {
  Scenario sc = load("district_oncoming.yaml");
  StatusOr<Environment> env = Environment::load(sc);
  ASSERT_TRUE(env.ok()) << env.status().message();
  const double r = sc.params.robot.radius_m;
  // Down from the scenario's goal until the centre is half a radius above the floor's rock.
  Vec3 low = sc.goal;
  while (env->field()->distance(low) > 0.5 * r) low.z() -= 0.02;
  ASSERT_TRUE(env->field()->isFree(low));
  sc.goal = low;
  sc.expected_path.points = {sc.start, sc.goal};
  StatusOr<SimulationResult> refused = simulate(sc, *env);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("goal: the robot (radius 0.4"), std::string::npos)
      << refused.status().message();
  EXPECT_NE(refused.status().message().find("does not fit there"), std::string::npos) << refused.status().message();
}

// Crossing traffic in open space: a 20 m straight path, 4-8 movers crossing it about when the
// robot gets there, 1-3 static discs; the tian2016 preset as it is.
Scenario crossingTraffic(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto U = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  Scenario s;
  s.name = "crossing-" + std::to_string(seed);
  s.file = s.name;
  s.seed = seed;
  s.start = Vec3(0, 0, 0);
  s.goal = Vec3(20, 0, 0);
  s.expected_path.points = {s.start, s.goal};
  s.params = LocalParams::preset(Method::kTian2016);
  s.params.robot = {0.3, 1.0, 0.5};
  s.dt_s = 0.1;
  s.t_max_s = 120;
  const int n_static = int(U(1, 4)), n_moving = int(U(4, 9));
  for (int i = 0; i < n_static; ++i) s.static_obstacles.push_back({Vec3(U(4, 16), U(-1.5, 1.5), 0), U(0.3, 0.6)});
  for (int i = 0; i < n_moving; ++i) {
    NamedObstacle m;
    m.name = "mover " + std::to_string(i + 1);
    const double x = U(3, 17), side = U(0, 1) < 0.5 ? -1.0 : 1.0, speed = U(0.2, 0.6);
    const double t_cross = x / 0.8 + U(-4, 4);
    m.obstacle.shape = map::RobotShape::sphere(U(0.2, 0.4));
    m.obstacle.velocity = Vec3(0, -side * speed, 0);
    m.obstacle.position = Vec3(x, side * speed * t_cross, 0);
    s.moving_obstacles.push_back(m);
  }
  return s;
}

// Tolerances (issue 7): >= 90 % arrive; an arrival never collides or stops short (the referee's
// verdict); the rest end honestly stuck or timed out, never in a collision.
TEST(Scenarios, RandomCrossingTraffic) {
  constexpr int kSeeds = 200;
  int counts[4] = {0, 0, 0, 0};
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const Scenario s = crossingTraffic(seed);
    ASSERT_TRUE(s.validate().ok()) << seed;
    StatusOr<SimulationResult> r = simulate(s, Environment::openSpace());
    ASSERT_TRUE(r.ok()) << r.status().message();
    ++counts[int(r->outcome)];
    if (r->arrived()) {
      EXPECT_EQ(r->collisions, 0) << seed;
      EXPECT_LE(r->final_goal_distance_m, r->arrival_tolerance_m) << seed;
    } else {
      std::printf("    seed %d: %s (%s)\n", int(seed), outcomeName(r->outcome), r->message.c_str());
    }
  }
  std::printf("    %d seeds: %d arrived, %d collision, %d stuck, %d timeout\n", kSeeds, counts[0], counts[1],
              counts[2], counts[3]);
  EXPECT_GE(counts[int(Outcome::kArrived)], kSeeds * 9 / 10);
  EXPECT_EQ(counts[int(Outcome::kCollision)], 0);
}

TEST(Scenarios, SameSeedSameTrajectory) {
  const Scenario s = crossingTraffic(7);
  StatusOr<SimulationResult> a = simulate(s, Environment::openSpace());
  StatusOr<SimulationResult> b = simulate(s, Environment::openSpace());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->trajectory.size(), b->trajectory.size());
  for (std::size_t i = 0; i < a->trajectory.size(); ++i) {
    EXPECT_EQ(a->trajectory[i].position, b->trajectory[i].position);
    EXPECT_EQ(a->trajectory[i].status, b->trajectory[i].status);
  }
}

// The papers' set-ups whose robots are ground vehicles (Tian 2016's rescue robot, Wang 2014's
// mobile robot in the U trap, Guo 2022's inspection robot on the VFF grid), run with that robot
// as a differential-drive ground vehicle: the same disc as its footprint, v_max and a_max as the
// paper's, yaw rate within 1 rad/s and 2 rad/s^2 (the defaults), `preset: paper` kept. Beside
// each, the file as it is (the free-flying disc of the papers' plots). The papers' outcomes are
// asserted where they are the papers' (arrival, the classic field stalling in the U trap, no
// contact); times and lengths are printed for docs/papers.md, not asserted: a robot that must turn
// before it moves is slower, by how much is what the table shows. (The sub-goal variant of Tian's
// polyline runs through the navigator: `adit simulate` on the file with the robot changed.)

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
