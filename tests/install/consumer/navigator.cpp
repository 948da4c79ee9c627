// SPDX-License-Identifier: BSD-3-Clause
// A robot's navigation against the installed library: load the mine map, plan the expected path,
// sense a roof fall across it, and replan around it. Exit 0 when the first path crosses the fall,
// the new one keeps clear of it and the robot drives on; 1 otherwise; 2 when the map cannot be read.
//
//   navigator_consumer MAP.yaml      (the bundled maps/district.yaml, as the district rescue)
#include <algorithm>
#include <cstdio>
#include <vector>

#include "adit/fusion/navigator.hpp"

int main(int argc, char** argv) {
  using namespace adit;
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MAP.yaml\n", argv[0]);
    return 2;
  }
  StatusOr<map::LoadedMap> loaded = map::loadMapAndSurvey(argv[1]);
  if (!loaded.ok()) {
    std::fprintf(stderr, "%s\n", loaded.status().message().c_str());
    return 2;
  }
  const map::Vec3 start(60, 0, -1.51), goal(130, 40, -3.51), fall(90, 20, -2.44);
  fusion::NavigatorParams params;
  params.local.robot.radius_m = 0.4;
  StatusOr<fusion::Navigator> nav = fusion::Navigator::create(std::move(loaded).value(), params, goal);
  if (!nav.ok()) {
    std::fprintf(stderr, "%s\n", nav.status().message().c_str());
    return 1;
  }
  if (Status s = nav->plan(start); !s.ok()) {
    std::fprintf(stderr, "plan: %s\n", s.message().c_str());
    return 1;
  }
  // How close a path comes to the fall's centre: every vertex and every point between them at 1 %
  // of the segment.
  const auto closestToFall = [&fall](const map::Polyline& path) {
    double closest = 1e9;
    for (std::size_t i = 0; i + 1 < path.points.size(); ++i)
      for (double s = 0; s <= 1.0; s += 0.01)
        closest = std::min(closest, (path.points[i] + s * (path.points[i + 1] - path.points[i]) - fall).norm());
    return closest;
  };
  // The fall must block the first plan, or a replan would prove nothing.
  const double before = closestToFall(nav->expectedPath());
  std::printf("planned: %zu break points, passing %.2f m from the fall's centre\n",
              nav->expectedPath().points.size(), before);
  if (before >= 3.0) {
    std::fprintf(stderr, "the planned path does not cross the fall\n");
    return 1;
  }
  // The roof fall: rock voxels (0.25 m apart) filling a 3 m ball, as a lidar would return them.
  std::vector<map::Vec3> rock;
  for (double x = -3; x <= 3; x += 0.25)
    for (double y = -3; y <= 3; y += 0.25)
      for (double z = -3; z <= 3; z += 0.25)
        if (map::Vec3(x, y, z).norm() <= 3.0) rock.push_back(fall + map::Vec3(x, y, z));
  local::RobotState state;
  state.position = start;
  const fusion::NavigatorCycle c = nav->cycle(0.0, state, rock, {}, 0.1);
  if (!c.replanned || c.status != fusion::NavigatorStatus::kDriving) {
    std::fprintf(stderr, "no replan around the fall (status %s)\n", fusion::navigatorStatusName(c.status));
    return 1;
  }
  // The new path keeps 3 m + the robot's radius from the fall's centre.
  const map::Polyline path = nav->expectedPath();
  const double closest = closestToFall(path);
  std::printf("replanned in %.3f s around the fall: %zu break points, closest %.2f m from its centre\n",
              c.replan_time_s, path.points.size(), closest);
  if (closest < 3.0 + 0.4) return 1;
  // And it drives on: the first set-points move the robot toward the new path's first break point.
  for (int k = 1; k <= 50; ++k) {
    const fusion::NavigatorCycle d = nav->cycle(0.1 * k, state, {}, {}, 0.1);
    if (d.status != fusion::NavigatorStatus::kDriving) {
      std::fprintf(stderr, "cycle %d: %s\n", k, fusion::navigatorStatusName(d.status));
      return 1;
    }
    state.position += 0.1 * d.command.velocity;
    state.velocity = d.command.velocity;
  }
  std::printf("drove %.2f m in 5 s\n", (state.position - start).norm());
  return (state.position - start).norm() > 0.5 ? 0 : 1;
}
