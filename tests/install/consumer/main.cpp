// SPDX-License-Identifier: BSD-3-Clause
// The README's control loop against the installed library: a robot drives a straight path past
// a moving obstacle; exit 0 when it arrives.
#include <cstdio>
#include <vector>

#include "adit/local/local_planner.hpp"

int main() {
  using namespace adit;
  local::World world;  // open space; a robot in a mine sets world.field = &distance_field
  StatusOr<local::LocalPlanner> planner =
      local::LocalPlanner::create(local::LocalParams::preset(local::Method::kTian2016), world);
  if (!planner.ok()) {
    std::fprintf(stderr, "%s\n", planner.status().message().c_str());
    return 2;
  }
  const map::Polyline path{{map::Vec3(0, 0, 0), map::Vec3(10, 0, 0)}};
  std::vector<map::MovingObstacle> sensed(1);
  sensed[0].shape = map::RobotShape::sphere(0.3);
  local::RobotState state;
  const double dt = 0.1;
  for (int k = 0; k < 1000; ++k) {
    sensed[0].position = map::Vec3(6.0, 4.0 - 0.4 * k * dt, 0.0);  // crossing the path
    sensed[0].velocity = map::Vec3(0, -0.4, 0);
    const local::StepCommand c = planner->step(state, path, sensed, dt);
    if (c.status == local::StepStatus::kArrived) {
      std::printf("arrived after %d periods\n", k);
      return 0;
    }
    if (c.status == local::StepStatus::kStuck || c.status == local::StepStatus::kRefused) return 1;
    state.position += 0.5 * (state.velocity + c.velocity) * dt;  // the robot follows the set-points
    state.velocity = c.velocity;
  }
  return 1;
}
