// SPDX-License-Identifier: BSD-3-Clause
// A robot developer's scenario test against the installed adit::sim: a scenario from YAML text
// (open space, a mover crossing the path), simulated and judged by the referee; exit 0 when the
// robot arrives without a collision.
#include <cstdio>

#include "adit/sim/scenario.hpp"
#include "adit/sim/simulator.hpp"

int main() {
  using namespace adit;
  StatusOr<sim::Scenario> sc = sim::parseScenario(R"(start: [0, 0, 0]
goal: [10, 0, 0]
robot: {radius: 0.3, v_max: 1.0, a_max: 0.5}
moving_obstacles: [{start: [6, 4, 0], velocity: [0, -0.4, 0], radius: 0.3}]
method: tian2016
t_max: 100
)", "crossing.yaml");
  if (!sc.ok()) {
    std::fprintf(stderr, "%s\n", sc.status().message().c_str());
    return 2;
  }
  StatusOr<sim::SimulationResult> run = sim::simulate(*sc, sim::Environment::openSpace());
  if (!run.ok()) {
    std::fprintf(stderr, "%s\n", run.status().message().c_str());
    return 2;
  }
  std::printf("%s after %.1f s, %d collisions\n", sim::outcomeName(run->outcome), run->arrival_time_s, run->collisions);
  return run->arrived() && run->collisions == 0 ? 0 : 1;
}
