// SPDX-License-Identifier: BSD-3-Clause
// Ground vehicles (issue 16): a wheeled or tracked robot drives on the roadway floor. Generated
// worlds, each with an independent check: the referee (FCL against the footprint's box), the
// floor found by a plain downward search, and for the pillar fields a grid search (breadth-first
// over 2-D cells the disc fits in) that says whether a passage exists at all.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/rock_points.hpp"
#include "adit/sim/simulator.hpp"
#include "support/pillar_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::local {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is the local planner's.
using namespace adit::sim;

constexpr double kPi = 3.14159265358979323846;

struct World {
  std::unique_ptr<map::OccupancyMap> map;
  std::unique_ptr<map::DistanceField> field;
  std::optional<Environment> env;
  void finish() {
    StatusOr<map::DistanceField> f = map::DistanceField::build(*map);
    ASSERT_TRUE(f.ok()) << f.status().message();
    field = std::make_unique<map::DistanceField>(std::move(*f));
    StatusOr<Environment> e = Environment::borrow(*map, *field);
    ASSERT_TRUE(e.ok()) << e.status().message();
    env.emplace(std::move(*e));
  }
  // The floor under p by a plain downward walk in 1 cm steps (independent of map::floorBelow).
  double floorUnder(const Vec3& p) const {
    for (double z = p.z(); z > p.z() - 6.0; z -= 0.01)
      if (!field->isFree(Vec3(p.x(), p.y(), z))) {
        const double res = field->resolution();
        return (std::floor(z / res) + 1.0) * res;
      }
    ADD_FAILURE() << "no floor under " << p.transpose();
    return 0.0;
  }
};

std::unique_ptr<World> roadway(const map::SurveyNetwork& net) {
  auto w = std::make_unique<World>();
  w->map = std::make_unique<map::OccupancyMap>(test::voxelizeOrFail(net));
  w->finish();
  return w;
}

// The bundled rescue robot's kind: a tracked vehicle, 1.0 x 0.7 m, 0.6 m high.
Scenario trackedRobot(Method m, const Vec3& start, const Vec3& goal) {
  Scenario sc;
  sc.name = "ground";
  sc.file = "generated";
  sc.params = LocalParams::preset(m);
  sc.params.robot = RobotLimits::trackedRescue();
  sc.start = start;
  sc.goal = goal;
  sc.expected_path.points = {start, goal};
  sc.dt_s = 0.1;
  sc.t_max_s = 120.0;
  return sc;
}

// Every sample stands on the floor (centre half the height above it) and keeps the limits.
void expectOnFloorWithinLimits(const World& w, const Scenario& sc, const SimulationResult& run) {
  const RobotLimits& r = sc.params.robot;
  double worst = 0.0;
  for (std::size_t i = 0; i < run.trajectory.size(); ++i) {
    const TrajectorySample& s = run.trajectory[i];
    const double above = s.position.z() - w.floorUnder(s.position);
    worst = std::max(worst, std::abs(above - 0.5 * r.height_m));
    EXPECT_LE(std::hypot(s.velocity.x(), s.velocity.y()), r.v_max_mps + 1e-6) << "t = " << s.t_s;
    if (i > 0) {
      const double turn = std::remainder(s.yaw - run.trajectory[i - 1].yaw, 2.0 * kPi);
      EXPECT_LE(std::abs(turn), r.omega_max_rps * sc.dt_s + 1e-9) << "t = " << s.t_s;
    }
  }
  // The floor is quantised to voxels: a voxel of difference on a slope.
  EXPECT_LE(worst, w.field->resolution() + 1e-6) << "the robot left the floor";
}

TEST(GroundVehicle, TrackedRobotDrivesAFlatRoadwayOnItsFloor) {
  const auto w = roadway(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), 30.0, 0.2));
  for (Method m : {Method::kClassic, Method::kTian2016, Method::kWang2014, Method::kVff, Method::kCvff, Method::kUuv}) {
    // Given 1.5 m up: the robot is put on the floor; the goal beside the north rib.
    Scenario sc = trackedRobot(m, Vec3(2, 0, 1.5), Vec3(27, 1.0, 1.5));
    StatusOr<SimulationResult> run = simulate(sc, *w->env);
    ASSERT_TRUE(run.ok()) << run.status().message();
    std::printf("%-9s %-9s t=%.1f s, path %.1f m, min clearance %.2f m, %s\n", methodName(m),
                outcomeName(run->outcome), run->trajectory.back().t_s, run->path_length_m, run->min_clearance_m,
                run->message.c_str());
    EXPECT_EQ(run->outcome, Outcome::kArrived) << methodName(m) << ": " << run->message;
    EXPECT_EQ(run->collisions, 0) << methodName(m);
    StatusOr<Scenario> placed = placeOnFloor(sc, *w->env);
    ASSERT_TRUE(placed.ok());
    expectOnFloorWithinLimits(*w, *placed, *run);
  }
}

// The tracked robot up a straight 4.5 m-wide roadway of `length` rising `rise`, from the
// fraction `from` of its length to `to`; it arrives without contact.
struct SlopeRun {
  std::unique_ptr<World> world;
  Scenario scenario;
  SimulationResult run;
};
SlopeRun upSlope(double length, double rise, double from, double to) {
  SlopeRun r;
  r.world = roadway(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), length, 0.2, rise));
  r.scenario = trackedRobot(Method::kTian2016, Vec3(from * length, 0, from * rise + 1.5),
                            Vec3(to * length, 0, to * rise + 1.5));
  StatusOr<SimulationResult> run = simulate(r.scenario, *r.world->env);
  EXPECT_TRUE(run.ok()) << run.status().message();
  if (!run.ok()) return r;
  r.run = std::move(*run);
  EXPECT_EQ(r.run.outcome, Outcome::kArrived) << r.run.message;
  EXPECT_EQ(r.run.collisions, 0);
  return r;
}

TEST(GroundVehicle, ClimbsAFiveDegreeInclineAlongItsFloor) {
  constexpr double kLength = 30.0;
  const double rise = kLength * std::tan(5.7 * kPi / 180.0);
  const SlopeRun r = upSlope(kLength, rise, 2.0 / 30.0, 0.9);
  ASSERT_FALSE(r.run.trajectory.empty());
  const World* w = r.world.get();
  const SimulationResult* run = &r.run;
  StatusOr<Scenario> placed = placeOnFloor(r.scenario, *w->env);
  ASSERT_TRUE(placed.ok());
  expectOnFloorWithinLimits(*w, *placed, *run);
  // The centre climbed with the floor.
  EXPECT_NEAR(run->trajectory.back().position.z() - run->trajectory.front().position.z(),
              (run->trajectory.back().position.x() - run->trajectory.front().position.x()) * rise / kLength, 0.25);
}

// A 0.2 m map turns a gentle slope into stairs a voxel high, every res / tan(slope) metres. A
// stair is no step (the band allows a voxel of quantisation): the robot pursues its path straight
// up, not swerving off it at every stair (a line of sight refused at each one sent the rescue
// robot 0.4-0.6 m sideways every few seconds in the district's sloping cross-cuts).
TEST(GroundVehicle, KeepsToItsPathUpAGentleSlopeQuantisedIntoStairs) {
  constexpr double kLength = 40.0;
  for (double deg : {1.5, 2.5, 4.0}) {
    const SlopeRun r = upSlope(kLength, kLength * std::tan(deg * kPi / 180.0), 0.05, 0.95);
    const SimulationResult* run = &r.run;
    ASSERT_FALSE(run->trajectory.empty());
    double off = 0.0;
    double off_x = 0.0;
    // Along the roadway, clear of its end faces (the field's repulsion from the face beyond the
    // goal is another matter).
    for (const TrajectorySample& s : run->trajectory)
      if (s.position.x() > 4.0 && s.position.x() < 34.0 && std::abs(s.position.y()) > off)
        off = std::abs(s.position.y()), off_x = s.position.x();
    std::printf("%.1f deg (a stair every %.1f m): arrived at %.1f s, at most %.3f m off the path (x = %.1f m)\n",
                deg, 0.2 / std::tan(deg * kPi / 180.0), run->trajectory.back().t_s, off, off_x);
    EXPECT_LT(off, 0.05) << deg << " deg: the robot swerved off its straight path";
  }
}

TEST(GroundVehicle, RefusesAStartWithNoFloorOrInRock) {
  const auto w = roadway(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), 12.0, 0.2));
  Scenario sc = trackedRobot(Method::kTian2016, Vec3(2, 0, -3.0), Vec3(10, 0, 1.5));
  StatusOr<SimulationResult> run = simulate(sc, *w->env);
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.status().message().find("start: inside rock"), std::string::npos) << run.status().message();
}

// A flat 10 m approach, then a ramp of `deg` for 8 m, then flat again: rock written onto the
// floor of a 6 m-high roadway (a survey's bend would give its own mitred floor).
std::unique_ptr<World> rampRoadway(double deg, double res) {
  auto w = std::make_unique<World>();
  w->map = std::make_unique<map::OccupancyMap>(
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.5, 6.0), 26.0, res)));
  StatusOr<map::DistanceField> f = map::DistanceField::build(*w->map);
  EXPECT_TRUE(f.ok());
  const std::optional<double> floor = map::floorBelow(*f, Vec3(5, 0, 1.5), 3.0);
  EXPECT_TRUE(floor);
  const double rise = 8.0 * std::tan(deg * kPi / 180.0);
  std::vector<Vec3> rock;
  for (double x = 0.5 * res; x < 26.0; x += res) {
    const double top = *floor + std::clamp(x - 10.0, 0.0, 8.0) * rise / 8.0;
    for (double y = -2.25 + 0.5 * res; y < 2.25; y += res)
      for (double z = *floor + 0.5 * res; z < top; z += res) rock.emplace_back(x, y, z);
  }
  EXPECT_TRUE(w->map->setVoxels(rock, map::VoxelState::kOccupied).ok());
  w->finish();
  return w;
}

TEST(GroundVehicle, ClimbsARampWithinMaxSlopeAndRefusesASteeperOne) {
  for (const double deg : {10.0, 25.0}) {
    const auto w = rampRoadway(deg, 0.1);
    const double rise = 8.0 * std::tan(deg * kPi / 180.0);
    Scenario sc = trackedRobot(Method::kTian2016, Vec3(2, 0, 1.5), Vec3(24, 0, rise + 1.5));
    sc.t_max_s = 90.0;
    StatusOr<SimulationResult> run = simulate(sc, *w->env);
    ASSERT_TRUE(run.ok()) << run.status().message();
    double x_max = 0.0;
    for (const TrajectorySample& t : run->trajectory) x_max = std::max(x_max, t.position.x());
    std::printf("%.0f deg ramp: %s at t = %.1f s, farthest x = %.2f m, %s\n", deg, outcomeName(run->outcome),
                run->trajectory.back().t_s, x_max, run->message.c_str());
    EXPECT_EQ(run->collisions, 0) << deg << " deg: " << run->message;
    StatusOr<Scenario> placed = placeOnFloor(sc, *w->env);
    ASSERT_TRUE(placed.ok());
    expectOnFloorWithinLimits(*w, *placed, *run);
    if (deg <= sc.params.robot.max_slope_deg) {
      EXPECT_EQ(run->outcome, Outcome::kArrived) << run->message;
    } else {
      // Steeper than max_slope_deg is rock: the robot stays at the foot, honestly not arrived.
      EXPECT_NE(run->outcome, Outcome::kArrived);
      EXPECT_LT(x_max, 10.5) << "it climbed a " << deg << " deg ramp";
    }
  }
}

TEST(GroundVehicle, AStepHigherThanMaxStepIsRockALowerOneIsDrivenOver) {
  // A 0.3 m step across the whole roadway at x = 12 m.
  auto w = std::make_unique<World>();
  w->map = std::make_unique<map::OccupancyMap>(
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), 24.0, 0.1)));
  {
    StatusOr<map::DistanceField> f = map::DistanceField::build(*w->map);
    ASSERT_TRUE(f.ok());
    const std::optional<double> floor = map::floorBelow(*f, Vec3(6, 0, 1.5), 3.0);
    ASSERT_TRUE(floor);
    std::vector<Vec3> step;
    for (double x = 12.05; x < 24.0; x += 0.1)
      for (double y = -2.3; y < 2.3; y += 0.1)
        for (double z = *floor + 0.05; z < *floor + 0.3; z += 0.1) step.emplace_back(x, y, z);
    ASSERT_TRUE(w->map->setVoxels(step, map::VoxelState::kOccupied).ok());
  }
  w->finish();
  for (const double max_step : {0.1, 0.35}) {
    Scenario sc = trackedRobot(Method::kTian2016, Vec3(2, 0, 1.5), Vec3(20, 0, 1.5));
    sc.params.robot.max_step_m = max_step;
    sc.t_max_s = 80.0;
    StatusOr<SimulationResult> run = simulate(sc, *w->env);
    ASSERT_TRUE(run.ok()) << run.status().message();
    double x_max = 0.0;
    for (const TrajectorySample& t : run->trajectory) x_max = std::max(x_max, t.position.x());
    std::printf("max_step %.2f m, 0.3 m step: %s at t = %.1f s, farthest x = %.2f m %s\n", max_step,
                outcomeName(run->outcome), run->trajectory.back().t_s, x_max, run->message.c_str());
    EXPECT_EQ(run->collisions, 0) << run->message;
    if (max_step > 0.3) {
      EXPECT_EQ(run->outcome, Outcome::kArrived) << run->message;
    } else {
      EXPECT_NE(run->outcome, Outcome::kArrived);
      EXPECT_LT(x_max, 12.0) << "it drove onto a step higher than max_step";
    }
  }
}

// Caught at full speed turning toward rock on the south side whose face is at y = `face`: every
// start the oracle calls savable ends without contact, by the referee.
void brakeTowardTheSouth(const World& w, double face, const char* what) {
  const RobotLimits robot = RobotLimits::trackedRescue();
  auto savable = [&](double y, double yaw, double rate) {
    double v = robot.v_max_mps, h = yaw, r = rate;
    for (double t = 0.0; v > 0.0; t += 1e-3) {
      y += v * std::sin(h) * 1e-3;
      h += r * 1e-3;
      v -= robot.a_max_mps2 * 1e-3;
      r = r < 0.0 ? std::min(0.0, r + robot.alpha_max_rps2 * 1e-3) : std::max(0.0, r - robot.alpha_max_rps2 * 1e-3);
      if (y - face - robot.radius_m < 0.03) return false;
    }
    return true;
  };
  int runs = 0;
  double least = std::numeric_limits<double>::infinity();
  for (double yaw = -0.2; yaw > -0.85; yaw -= 0.15) {
    for (double rate = -0.3; rate > -1.05; rate -= 0.35) {
      for (double y = face + 1.85; y > face + 1.0; y -= 0.2)
        for (double goal_x : {9.5, 11.0, 16.0}) {
        if (!savable(y, yaw, rate)) continue;
        // The goal lies along the rock ahead: the wish pulls the robot down toward it.
        Scenario sc = trackedRobot(Method::kTian2016, Vec3(8, y, 1.5), Vec3(goal_x, face + 0.65, 1.5));
        StatusOr<Scenario> placed = placeOnFloor(sc, *w.env);
        ASSERT_TRUE(placed.ok()) << placed.status().message();
        sc = *placed;
        local::World world;
        world.field = w.field.get();
        StatusOr<LocalPlanner> planner = LocalPlanner::create(sc.params, world);
        ASSERT_TRUE(planner.ok()) << planner.status().message();
        RobotState state;
        state.position = sc.start;
        state.yaw = yaw;
        state.yaw_rate = rate;
        state.velocity = robot.v_max_mps * Vec3(std::cos(yaw), std::sin(yaw), 0.0);
        SimulationResult res;
        for (int k = 0; k < 60; ++k) {
          const StepCommand c = planner->step(state, sc.expected_path, {}, sc.dt_s);
          if (c.status == StepStatus::kArrived || c.status == StepStatus::kStuck || c.status == StepStatus::kRefused) break;
          refereePeriod(sc, *w.env, c, k * sc.dt_s, state, res);
        }
        ++runs;
        least = std::min(least, res.min_clearance_m);
        EXPECT_EQ(res.collisions, 0) << what << ": yaw " << yaw << ", yaw rate " << rate << ", y " << y << ", goal x " << goal_x;
      }
    }
  }
  std::printf("%d savable runs caught turning toward %s at full speed: least clearance %.3f m\n", runs, what, least);
  EXPECT_GE(runs, 20);
}

// A tracked robot cannot stop turning at once (alpha_max): caught at speed turning toward a rib,
// it keeps turning while it brakes, and its stopping run curves toward the rib. The envelope must
// hold that curved run clear, not the straight one (a campaign collision: the robot backed off a
// machine diagonally at 0.9 m/s and stopped with its covering circle 1 mm from the rib). A fan of
// positions, headings, yaw rates and goals toward the south rib at full speed; the ones the robot can
// still save (an oracle: braking at a_max while the yaw rate falls to zero at alpha_max, in 1 ms
// steps, keeps the covering circle 3 cm off the rib) must end without contact, by the referee.
TEST(GroundVehicle, BrakingWhileTurningTowardARibStopsClearOfIt) {
  const auto w = roadway(test::straightRoadway(map::CrossSection::rectangle(4.5, 3.5), 30.0, 0.2));
  brakeTowardTheSouth(*w, -2.25, "the rib");
}

// The local planner alone from sc.start at rest, heading `yaw`, each period judged by the referee
// (into `res`), until it arrives, is stuck or refused, or `periods` pass; its last status, and
// where it ended in `at`.
StepStatus driveFromRest(const World& w, Scenario sc, double yaw, int periods, SimulationResult& res, Vec3* at) {
  StatusOr<Scenario> placed = placeOnFloor(sc, *w.env);
  EXPECT_TRUE(placed.ok()) << placed.status().message();
  if (!placed.ok()) return StepStatus::kRefused;
  sc = *placed;
  local::World world;
  world.field = w.field.get();
  StatusOr<LocalPlanner> planner = LocalPlanner::create(sc.params, world);
  EXPECT_TRUE(planner.ok()) << planner.status().message();
  if (!planner.ok()) return StepStatus::kRefused;
  RobotState state;
  state.position = sc.start;
  state.yaw = yaw;
  StepStatus last = StepStatus::kFollowing;
  for (int k = 0; k < periods; ++k) {
    const StepCommand c = planner->step(state, sc.expected_path, {}, sc.dt_s);
    last = c.status;
    if (c.status == StepStatus::kArrived || c.status == StepStatus::kStuck || c.status == StepStatus::kRefused) break;
    refereePeriod(sc, *w.env, c, k * sc.dt_s, state, res);
  }
  *at = state.position;
  return last;
}

// A 5 m roadway with a bench 0.4 m high along the south rib's foot, its face at y = -1.8 (a real
// rib bulges at the floor).
std::unique_ptr<World> benchAtTheRibsFoot() {
  auto w = std::make_unique<World>();
  w->map = std::make_unique<map::OccupancyMap>(
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(5.0, 3.5), 30.0, 0.2)));
  std::vector<Vec3> bench;
  for (double x = 0.1; x < 30.0; x += 0.2)
    for (double y = -2.5; y < -1.8; y += 0.2)
      for (double z : {0.1, 0.3}) bench.emplace_back(x, y, z);
  EXPECT_TRUE(w->map->setVoxels(bench, map::VoxelState::kOccupied).ok());
  w->finish();
  return w;
}

// The same toward a bench 0.4 m high along the rib's foot (a real rib bulges at the floor): the
// field's sphere, lifted off the floor, barely sees it; the band (what the body can hit) does.
TEST(GroundVehicle, BrakingTowardABenchAtTheRibsFootStopsClearOfIt) {
  const auto w = benchAtTheRibsFoot();
  brakeTowardTheSouth(*w, -1.8, "a bench at the rib's foot");
}

// Stopped along a bench at a rib's foot with its goal across the roadway, a tracked robot must
// turn about, and turning on the spot swings the box's corners out to its covering circle: 0.61 m
// from its centre where its side stood 0.35 m off it. The covering circle already reaches into the
// bench (a real floor rising into a rib does this: a Koutzi run turned on the spot beside one and
// touched). It must turn only as far as its corners stay clear and edge away as it turns, never
// into the bench, by the referee; it gets across.
TEST(GroundVehicle, TurningAboutBesideABenchKeepsTheBoxCornersOffIt) {
  const auto w = benchAtTheRibsFoot();
  int runs = 0;
  for (const double gap : {0.06, 0.12, 0.2})
    for (const double yaw : {0.0, 0.3, kPi, -0.2}) {
      // The box's side parallel to the bench (or nearly), `gap` off its face at y = -1.8.
      const double half = 0.5 * std::abs(std::sin(yaw)) * 1.0 + 0.5 * std::abs(std::cos(yaw)) * 0.7;
      const Scenario sc = trackedRobot(Method::kTian2016, Vec3(15, -1.8 + half + gap, 1.5), Vec3(15, 1.6, 1.5));
      SimulationResult res;
      Vec3 at;
      const StepStatus last = driveFromRest(*w, sc, yaw, 400, res, &at);
      ++runs;
      EXPECT_EQ(res.collisions, 0) << "gap " << gap << ", yaw " << yaw;
      EXPECT_EQ(last, StepStatus::kArrived) << "gap " << gap << ", yaw " << yaw << ": at " << at.transpose();
    }
  EXPECT_EQ(runs, 12);
}

// Its covering circle already in a bench at its side and a pillar's face a few centimetres off its
// front, a tracked robot whose goal lies past the pillar turns to go round it: turning on the spot,
// its front corner swung into the pillar's face between two of the band's 24 nearest points (they
// sample the rock by direction from the centre, not from the corner). The turn is checked against
// the voxels along the box's outline; driving, the box at its heading keeps its own clearance. By
// the referee, no contact.
TEST(GroundVehicle, ABoxBesideABenchDoesNotSwingItsCornerIntoAPillar) {
  const auto w = benchAtTheRibsFoot();
  std::vector<Vec3> pillar;
  for (double x = 15.7; x < 16.1; x += 0.2)
    for (double y = -1.7; y < -0.9; y += 0.2)
      for (double z = 0.1; z < 2.0; z += 0.2) pillar.emplace_back(x, y, z);
  ASSERT_TRUE(w->map->setVoxels(pillar, map::VoxelState::kOccupied).ok());
  ASSERT_TRUE(w->field->update(*w->map, map::Aabb{Vec3(15.4, -2.0, -0.2), Vec3(16.4, -0.6, 2.2)}).ok());
  int runs = 0;
  for (const double front : {0.56, 0.6, 0.68})
    for (const double side : {0.42, 0.47}) {
      const Scenario sc =
          trackedRobot(Method::kTian2016, Vec3(15.6 - front, -1.8 + side, 1.5), Vec3(26, -1.8 + side, 1.5));
      SimulationResult res;
      Vec3 at;
      driveFromRest(*w, sc, 0.0, 300, res, &at);
      ++runs;
      EXPECT_EQ(res.collisions, 0) << "front " << front << ", side " << side << ": at " << at.transpose();
    }
  EXPECT_EQ(runs, 6);
}

TEST(GroundVehicle, EachDriveKeepsItsKinematics) {
  // The goal behind the robot's heading: differential and skid turn on the spot, holonomic moves
  // at once; Ackermann turns with its steering (yaw rate <= |v| tan(max_steer) / wheelbase), so in
  // a 5 m roadway (turning circle 2.1 m, plus the body) it turns about forward and back, and it
  // changes lane on the way to a goal ahead.
  const auto w = roadway(test::straightRoadway(map::CrossSection::rectangle(5.0, 3.5), 30.0, 0.2));
  struct Case {
    DriveType drive;
    Vec3 goal;
    bool arrives;
  };
  const Case cases[] = {{DriveType::kDifferential, Vec3(5, 0, 1.5), true},
                        {DriveType::kSkid, Vec3(5, 0, 1.5), true},
                        {DriveType::kHolonomic, Vec3(5, 0, 1.5), true},
                        {DriveType::kAckermann, Vec3(27, 1.2, 1.5), true},
                        {DriveType::kAckermann, Vec3(5, 0, 1.5), false}};
  for (const Case& k : cases) {
    const DriveType d = k.drive;
    Scenario sc = trackedRobot(Method::kTian2016, Vec3(15, 0, 1.5), k.goal);
    sc.params.robot.drive = d;
    sc.expected_path.points = {Vec3(15, 0, 1.5), Vec3(15.5, 0, 1.5), k.goal};  // start heading: +x
    sc.t_max_s = 90.0;
    StatusOr<SimulationResult> run = simulate(sc, *w->env);
    ASSERT_TRUE(run.ok()) << run.status().message();
    std::printf("%-12s to (%.0f, %.1f): %s at t = %.1f s, path %.1f m %s\n", driveTypeName(d), k.goal.x(), k.goal.y(),
                outcomeName(run->outcome), run->trajectory.back().t_s, run->path_length_m, run->message.c_str());
    if (k.arrives) {
      EXPECT_EQ(run->outcome, Outcome::kArrived) << driveTypeName(d) << ": " << run->message;
    }
    EXPECT_EQ(run->collisions, 0);
    const RobotLimits& r = sc.params.robot;
    for (std::size_t i = 1; i < run->trajectory.size(); ++i) {
      const TrajectorySample &a = run->trajectory[i - 1], &b = run->trajectory[i];
      const double yaw_rate = std::remainder(b.yaw - a.yaw, 2.0 * kPi) / sc.dt_s;
      const double speed = std::hypot(b.velocity.x(), b.velocity.y());
      if (d == DriveType::kAckermann) {
        ASSERT_LE(std::abs(yaw_rate), speed * std::tan(r.max_steer_deg * kPi / 180.0) / r.wheelbase() + 1e-6)
            << "t = " << b.t_s << ": a car cannot turn faster than its steering allows";
      }
      if (d != DriveType::kHolonomic && speed > 0.05) {
        // Velocity along the heading (forward or reversing), never sideways.
        const double across = std::abs(-std::sin(b.yaw) * b.velocity.x() + std::cos(b.yaw) * b.velocity.y());
        ASSERT_LE(across, 1e-6) << "t = " << b.t_s << ": " << driveTypeName(d) << " moved sideways";
      }
    }
  }
}

// ---- pillar fields: the BARN benchmark's kind of clutter, as a 1.95 m slab -----------------

TEST(GroundVehicle, PillarFieldsOnTheFloorNoCollisionWithTheOraclePath) {
  // The case: a 0.27 m robot among 0.15 m pillars in a 1.95 m slab (as a sphere it bobbed
  // between floor and roof and collided in all 60 worlds). Here a differential robot, circle:0.27,
  // 0.5 m high, follows the oracle's passage as its expected path.
  constexpr double kRadius = 0.27;
  int worlds = 0, passable = 0, arrived = 0, collided = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    test::PillarFieldSpec spec;
    spec.seed = seed;
    const std::unique_ptr<test::PillarField> field = test::makePillarField(spec);
    ASSERT_TRUE(field->field);
    const test::PillarField& f = *field;
    StatusOr<Environment> env = Environment::borrow(*f.map, *f.field);
    ASSERT_TRUE(env.ok()) << env.status().message();
    ++worlds;
    const std::vector<std::pair<int, int>> cells = test::gridPassage(f, kRadius, 0.05, 2, spec.cols - 3);
    if (cells.empty()) continue;
    ++passable;
    Scenario sc;
    sc.name = "pillars";
    sc.file = "pillars-" + std::to_string(seed);
    sc.params = LocalParams::preset(Method::kTian2016);
    // Clutter's influence distance: with the roadway default (2 m), and the field alone, the
    // pillars' repulsion pushed the robot off the passage (2 of 12 arrived, no collision).
    sc.params.tian2016.rho0_m = 0.4;
    RobotLimits& r = sc.params.robot;
    r.mode = RobotMode::kGround;
    r.drive = DriveType::kDifferential;
    r.footprint.radius_m = kRadius;
    r.radius_m = kRadius;
    r.height_m = 0.5;
    r.v_max_mps = 0.5;
    const double zc = f.floor_z + 0.5 * r.height_m;
    // The passage thinned to its turns: the expected path's break points.
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const bool turn = i == 0 || i + 1 == cells.size() ||
                        (cells[i + 1].first - cells[i].first) != (cells[i].first - cells[i - 1].first) ||
                        (cells[i + 1].second - cells[i].second) != (cells[i].second - cells[i - 1].second);
      if (turn) sc.expected_path.points.push_back(f.cellCentre(cells[i].first, cells[i].second, zc));
    }
    sc.start = sc.expected_path.points.front();
    sc.goal = sc.expected_path.points.back();
    sc.t_max_s = 4.0 * 12.0 / r.v_max_mps;
    StatusOr<SimulationResult> run = simulate(sc, *env);
    ASSERT_TRUE(run.ok()) << run.status().message();
    double z_lo = 1e9, z_hi = -1e9;
    for (const TrajectorySample& s : run->trajectory) {
      z_lo = std::min(z_lo, s.position.z());
      z_hi = std::max(z_hi, s.position.z());
    }
    std::printf("seed %2llu: %-8s t=%.1f s, %zu break points, min clearance %.3f m, z %.3f..%.3f %s\n",
                static_cast<unsigned long long>(seed), outcomeName(run->outcome), run->trajectory.back().t_s,
                sc.expected_path.points.size(), run->min_clearance_m, z_lo, z_hi, run->message.c_str());
    EXPECT_NEAR(z_lo, zc, 1e-6) << "seed " << seed << ": the robot left the floor";
    EXPECT_NEAR(z_hi, zc, 1e-6) << "seed " << seed << ": the robot left the floor";
    arrived += run->arrived();
    collided += run->collisions > 0;
    EXPECT_EQ(run->collisions, 0) << "seed " << seed << ": " << run->message;
  }
  std::printf("%d worlds, %d passable for the robot (grid search), %d arrived, %d collided\n", worlds, passable,
              arrived, collided);
  EXPECT_GE(passable, 6) << "the generator should make mostly passable fields";
  // Measured: 12 of 12 cross, pursuing the oracle's passage (PursuitParams). The field alone
  // (pursuit: false) crossed 8: the others ended stuck or out of time between pillars.
  EXPECT_EQ(arrived, passable) << "every passable field crossed";
}

}  // namespace
}  // namespace adit::local
