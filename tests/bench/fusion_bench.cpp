// SPDX-License-Identifier: BSD-3-Clause
// The per-period sub-goal selection (fusion::pickSubgoal, Tian 2016 §2.3) beside the local step
// it feeds, at the same robot states: the period starts (every 1 s) of the Tian polyline run
// (maps/scenarios/tian2016_polyline.yaml). The ratio selection / step is printed at the end: the
// selection runs once per period t0, the step every dt. Not run by CTest.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <string>
#include <vector>

#include "adit/fusion/subgoal_selector.hpp"
#include "adit/local/local_planner.hpp"
#include "adit/sim/simulator.hpp"

namespace {

using namespace adit;

struct PeriodStart {
  local::RobotState state;
  std::vector<map::MovingObstacle> moving;  // where the movers are at that time
  std::size_t segment = 0;
};

struct Setup {
  sim::Scenario scenario;
  std::vector<PeriodStart> starts;
};

const Setup& setup() {
  static const Setup s = [] {
    StatusOr<sim::Scenario> sc = sim::loadScenario(std::string(ADIT_MAPS_DIR) + "/scenarios/tian2016_polyline.yaml");
    if (!sc.ok()) std::abort();
    StatusOr<sim::SimulationResult> run = sim::simulate(*sc, sim::Environment::openSpace());
    if (!run.ok()) std::abort();
    Setup out{*sc, {}};
    const auto per_period = std::size_t(sc->subgoal_period_s / sc->dt_s + 0.5);
    for (std::size_t i = 0; i < run->trajectory.size(); i += per_period) {
      const sim::TrajectorySample& t = run->trajectory[i];
      PeriodStart p;
      p.state.position = t.position;
      p.state.velocity = t.velocity;
      for (const sim::NamedObstacle& m : sc->moving_obstacles) {
        map::MovingObstacle now = m.obstacle;
        now.position = m.obstacle.positionAt(t.t_s);
        now.velocity = m.obstacle.velocityAt(t.t_s);
        p.moving.push_back(now);
      }
      sc->expected_path.nearestPoint(t.position, &p.segment);
      out.starts.push_back(std::move(p));
    }
    return out;
  }();
  return s;
}

double g_selection_ns = 0.0, g_step_ns = 0.0;  // CPU time per iteration, for the ratio

double threadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e9 + double(ts.tv_nsec);
}

void BM_SubgoalSelection(benchmark::State& st) {
  const Setup& s = setup();
  const fusion::SubgoalParams params = sim::subgoalParamsFor(s.scenario);
  const std::vector<map::Vec3>& path = s.scenario.expected_path.points;
  std::size_t i = 0, optimized = 0;
  const double t0 = threadCpuNs();
  for (auto _ : st) {
    const PeriodStart& p = s.starts[i++ % s.starts.size()];
    const local::SubgoalPick pick = fusion::pickSubgoal(p.state, path[p.segment], path[p.segment + 1], &p.moving,
                                                        &s.scenario.static_obstacles, nullptr, s.scenario.params, params);
    optimized += pick.kind == "optimized";
    benchmark::DoNotOptimize(pick.aim);
  }
  g_selection_ns = (threadCpuNs() - t0) / double(st.iterations());
  st.counters["optimized_share"] = double(optimized) / double(st.iterations());
}

void BM_LocalStep(benchmark::State& st) {
  const Setup& s = setup();
  local::World world;
  world.shape = map::RobotShape::sphere(s.scenario.params.robot.radius_m);
  world.static_obstacles = s.scenario.static_obstacles;
  StatusOr<local::LocalPlanner> planner = local::LocalPlanner::create(s.scenario.params, world);
  if (!planner.ok()) std::abort();
  std::size_t i = 0;
  const double t0 = threadCpuNs();
  for (auto _ : st) {
    const PeriodStart& p = s.starts[i++ % s.starts.size()];
    // A fresh monitor per state: the states jump along the run, and a monitor that saw no progress
    // for its window would answer `stuck` at once instead of computing the field.
    planner->reset();
    const local::StepCommand c = planner->step(p.state, s.scenario.expected_path, p.moving, s.scenario.dt_s);
    benchmark::DoNotOptimize(c.velocity);
  }
  g_step_ns = (threadCpuNs() - t0) / double(st.iterations());
}

BENCHMARK(BM_SubgoalSelection)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LocalStep)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  if (g_selection_ns > 0.0 && g_step_ns > 0.0)
    std::printf("\nCPU time, sub-goal selection / local step at the same %zu period starts: %.0fx (%.1f us vs %.2f us)\n",
                setup().starts.size(), g_selection_ns / g_step_ns, g_selection_ns / 1e3, g_step_ns / 1e3);
  benchmark::Shutdown();
  return 0;
}
