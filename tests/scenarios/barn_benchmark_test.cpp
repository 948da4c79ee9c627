// SPDX-License-Identifier: BSD-3-Clause
// A ground benchmark like BARN (Perille et al., "Benchmarking Metric Ground Navigation", SSRR
// 2020): pillar fields made by its cellular-automaton rules (0.15 m cells, 30 x 30 in a 4.5 m-wide
// corridor, fill 10-30 %, 1-4 smoothing passes), a differential-drive robot of 0.51 x 0.43 m
// (BARN's Jackal) at up to 2 m/s, start 2 m before the field and goal 3.4 m after it, the expected
// path planned by adit's global layer (as `expected_path: plan`), the local layer driving it.
//
// The oracle is independent of adit's planners: a breadth-first search over the cells where a
// disc fits, for the robot's covering circle (what adit drives: sufficient for the box) and for
// its inscribed circle (necessary for the box). Each world reports BARN's score,
//   success x t_opt / clip(t, 2 t_opt, 8 t_opt),  t_opt = oracle path length / v_max,
// beside which BARN's paper puts DWA's 0.17 (its mean over 300 worlds).
//
// Asserted: no collision in any world either way; with pursuit (PursuitParams, the default for
// ground robots) at least 95 % of the worlds the covering circle passes are crossed, and more
// than by the field alone, which runs beside it world by world.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "adit/fusion/navigator.hpp"
#include "adit/map/world.hpp"
#include "adit/sim/simulator.hpp"
#include "support/pillar_field.hpp"

namespace adit::fusion {
namespace {

// The scenarios, the runs and their referee are adit::sim's; what is tested is adit::fusion's.
using namespace adit::sim;

constexpr int kStartCol = 3, kFirstCol = 17, kLastCol = 47, kGoalCol = 70, kCols = 74, kRows = 30;

struct WorldResult {
  bool passable_inscribed = false;
  bool passable_covering = false;
  bool planned = false;
  sim::Outcome outcome = sim::Outcome::kTimeout;
  int collisions = 0;
  double time_s = 0.0;
  double optimal_s = 0.0;
  double score = 0.0;
};

local::RobotLimits jackal() {
  local::RobotLimits r;
  r.mode = local::RobotMode::kGround;
  r.drive = local::DriveType::kDifferential;
  r.footprint.box = true;
  r.footprint.length_m = 0.51;
  r.footprint.width_m = 0.43;
  r.height_m = 0.4;
  r.radius_m = r.footprint.circumradius();
  r.v_max_mps = 2.0;
  r.a_max_mps2 = 2.0;
  r.omega_max_rps = 2.0;
  r.alpha_max_rps2 = 4.0;
  return r;
}

WorldResult runWorld(int index, bool pursuit) {
  WorldResult out;
  test::PillarFieldSpec spec;
  spec.seed = std::uint64_t(1000 + index);
  spec.rows = kRows;
  spec.cols = kCols;
  spec.first_col = kFirstCol;
  spec.last_col = kLastCol;
  // BARN's range of difficulty: fill 10-30 %, 1-4 automaton passes, spread evenly over the worlds.
  spec.fill = 0.10 + 0.05 * (index % 5);
  spec.smoothing = 1 + (index / 5) % 4;
  const std::unique_ptr<test::PillarField> f = test::makePillarField(spec);
  if (!f->field) return out;
  const local::RobotLimits robot = jackal();
  const int mid = kRows / 2;
  const double zc = f->floor_z + 0.5 * robot.height_m;
  const map::Vec3 start = f->cellCentre(mid, kStartCol, zc), goal = f->cellCentre(mid, kGoalCol, zc);
  const auto inscribed = test::gridPassage(*f, 0.5 * robot.footprint.width_m, 0.0, {mid, kStartCol}, {mid, kGoalCol});
  const auto covering = test::gridPassage(*f, robot.radius_m, 0.0, {mid, kStartCol}, {mid, kGoalCol});
  out.passable_inscribed = !inscribed.empty();
  out.passable_covering = !covering.empty();
  if (!out.passable_covering) return out;
  out.optimal_s = test::pulledLength(*f, covering, robot.radius_m, 0.0) / robot.v_max_mps;

  NavigatorParams np;
  np.local = local::LocalParams::preset(local::Method::kTian2016);
  np.local.robot = robot;
  np.local.pursuit.enabled = pursuit;
  // Clutter: the envelope's keep. With the roadway default (0.2 m) no world is planned: the
  // pillars' gaps are narrower than the robot's circle and two margins.
  np.global.safety_margin_m = 0.05;
  np.global.seed = std::uint32_t(spec.seed);
  np.global.max_unsolved_iterations = 20000;
  np.global.time_budget_s = 60.0;
  map::LoadedMap loaded{*f->map, f->survey};
  StatusOr<Navigator> nav = Navigator::create(std::move(loaded), map::DistanceField(*f->field), np, goal);
  EXPECT_TRUE(nav.ok()) << nav.status().message();
  if (!nav.ok()) return out;
  if (Status s = nav->plan(start); !s.ok()) {
    out.outcome = sim::Outcome::kNoRoute;
    return out;
  }
  out.planned = true;

  sim::Scenario sc;
  sc.name = "barn-" + std::to_string(index);
  sc.file = "generated";
  sc.params = np.local;
  sc.start = start;
  sc.goal = goal;
  sc.expected_path = nav->expectedPath();
  sc.dt_s = 0.1;
  sc.t_max_s = 8.0 * out.optimal_s + 10.0;
  StatusOr<sim::Environment> env = sim::Environment::borrow(*f->map, *f->field);
  EXPECT_TRUE(env.ok());
  if (!env.ok()) return out;
  StatusOr<sim::SimulationResult> run = sim::simulate(sc, *env);
  EXPECT_TRUE(run.ok()) << run.status().message();
  if (!run.ok()) return out;
  out.outcome = run->outcome;
  out.collisions = run->collisions;
  out.time_s = run->trajectory.back().t_s;
  if (run->collisions > 0) std::printf("  world %d: %s\n", index, run->message.c_str());
  if (run->arrived() && run->collisions == 0)
    out.score = out.optimal_s / std::clamp(out.time_s, 2.0 * out.optimal_s, 8.0 * out.optimal_s);
  return out;
}

struct Tally {
  int inscribed = 0, covering = 0, planned = 0, arrived = 0, collided = 0;
  double score_sum = 0.0;
  void add(const WorldResult& w) {
    inscribed += w.passable_inscribed;
    covering += w.passable_covering;
    planned += w.planned;
    arrived += w.passable_covering && w.outcome == sim::Outcome::kArrived && w.collisions == 0;
    collided += w.collisions > 0;
    score_sum += w.score;
  }
  double success() const { return covering ? double(arrived) / covering : 0.0; }
  double score() const { return covering ? score_sum / covering : 0.0; }
};

// Both ways in one run, world by world: the path pursued where it is clear (the default for
// ground robots) and the field alone (`pursuit: false`).
TEST(BarnBenchmark, JackalCrossesPillarFieldsWithoutCollision) {
  constexpr int kWorlds = 150;
  Tally on, off;
  for (int i = 0; i < kWorlds; ++i) {
    const WorldResult w = runWorld(i, true), f = runWorld(i, false);
    on.add(w);
    off.add(f);
    if (w.passable_covering)
      std::printf("world %3d fill %.2f passes %d: pursuit %-8s t=%5.1f s score %.3f | field %-8s t=%5.1f s score %.3f "
                  "(opt %.1f s)\n",
                  i, 0.10 + 0.05 * (i % 5), 1 + (i / 5) % 4, sim::outcomeName(w.outcome), w.time_s, w.score,
                  sim::outcomeName(f.outcome), f.time_s, f.score, w.optimal_s);
    EXPECT_EQ(w.collisions, 0) << "world " << i;
    EXPECT_EQ(f.collisions, 0) << "world " << i << ", field alone";
  }
  std::printf("%d worlds: passable for the inscribed circle %d, the covering circle %d; planned %d\n", kWorlds,
              on.inscribed, on.covering, on.planned);
  for (const auto& [name, t] : {std::pair<const char*, const Tally&>{"pursuit", on}, {"field alone", off}})
    std::printf("  %-11s arrived %d of %d (%.1f %%), collided %d, mean BARN score %.3f (DWA in BARN: 0.17)\n", name,
                t.arrived, t.covering, 100.0 * t.success(), t.collided, t.score());
  EXPECT_GE(on.covering, kWorlds / 3) << "the generator should make many passable worlds";
  EXPECT_EQ(on.planned, on.covering) << "the global layer should plan every world the oracle passes";
  EXPECT_EQ(on.collided, 0);
  EXPECT_EQ(off.collided, 0);
  // Measured: 63 of 66 (95.5 %) with pursuit, score 0.459; the field alone far fewer.
  EXPECT_GE(on.success(), 0.95);
  EXPECT_GT(on.success(), off.success());
  EXPECT_GT(on.score(), off.score());
}

}  // namespace
}  // namespace adit::fusion
