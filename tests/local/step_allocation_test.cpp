// SPDX-License-Identifier: BSD-3-Clause
// step() must not allocate: this binary replaces the global operator new with a counting one and
// runs every model in a roadway with moving obstacles.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <optional>

#include "adit/local/local_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/rock_points.hpp"
#include "support/synthetic_roadway.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace adit::local {
namespace {

TEST(StepAllocation, NoHeapAllocationPerStep) {
  const map::OccupancyMap m = test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 20.0));
  StatusOr<map::DistanceField> f = map::DistanceField::build(m);
  ASSERT_TRUE(f.ok());
  const map::Polyline path{{Vec3(1, 0, 1.5), Vec3(10, 0.5, 1.5), Vec3(19, 0, 1.5)}};
  std::vector<map::MovingObstacle> mov(20);
  for (std::size_t i = 0; i < mov.size(); ++i) {
    mov[i].shape = i % 3 == 0 ? map::RobotShape::sphere(0.3)
                   : i % 3 == 1 ? map::RobotShape::box(Vec3(1, 0.6, 0.8)) : map::RobotShape::cylinder(0.3, 1.0);
    mov[i].position = Vec3(2.0 + 0.8 * double(i), (i % 2 ? 1.0 : -1.0), 1.5);
    mov[i].velocity = Vec3(-0.3, 0.05, 0);
  }
  for (Method method : {Method::kClassic, Method::kTian2016, Method::kWang2014, Method::kVff, Method::kCvff, Method::kUuv}) {
    World w;
    w.field = &*f;
    w.static_obstacles = {{Vec3(6, -1, 1.5), 0.4}};
    StatusOr<LocalPlanner> p = LocalPlanner::create(LocalParams::preset(method), w);
    ASSERT_TRUE(p.ok());
    RobotState s;
    s.position = Vec3(1.5, 0, 1.5);
    const long before = g_allocations.load();
    int steps = 0;
    for (; steps < 300; ++steps) {
      // Every other period with a caller's sub-goal (as the fusion layer's selection gives).
      if (steps % 20 == 10) p->setSubgoal(s.position + Vec3(0.8, 0.3, 0));
      if (steps % 20 == 0) p->clearSubgoal();
      // And now and then under the operator's hand (issue 11).
      if (steps % 30 == 15) p->setOverride(Vec3(0.3, 0.8, 0), steps % 60 == 15);
      if (steps % 30 == 25) p->clearOverride();
      const StepCommand c = p->step(s, path, mov.data(), mov.size(), 0.1);
      if (c.status == StepStatus::kArrived || c.status == StepStatus::kStuck) break;
      s.position += 0.05 * (s.velocity + c.velocity);
      s.velocity = c.velocity;
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << methodName(method) << " over " << steps << " steps";
    EXPECT_GT(steps, 10) << methodName(method);
  }
}

// Ground mode: the band scan, the floor's plane, pursuit, the drive command, the envelope's
// stopping runs and the box's turn checks, for a tracked box, a differential disc and an Ackermann
// box, driving along the floor among movers (the band's cache is sized when the planner is made).
TEST(StepAllocation, NoHeapAllocationPerGroundStep) {
  const map::OccupancyMap m = test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 20.0));
  StatusOr<map::DistanceField> f = map::DistanceField::build(m);
  ASSERT_TRUE(f.ok());
  const std::optional<double> floor = map::floorBelow(*f, Vec3(1.5, 0, 1.5), 3.0);
  ASSERT_TRUE(floor.has_value());
  const double z = *floor + 0.3;
  const map::Polyline path{{Vec3(1, 0, z), Vec3(10, 0.5, z), Vec3(19, 0, z)}};
  std::vector<map::MovingObstacle> mov(20);
  for (std::size_t i = 0; i < mov.size(); ++i) {
    mov[i].shape = i % 2 ? map::RobotShape::cylinder(0.3, 1.6) : map::RobotShape::box(Vec3(1, 0.6, 0.8));
    // Ahead, along the walls, going the robot's way a little slower than it may.
    mov[i].position = Vec3(4.0 + 0.8 * double(i), (i % 2 ? 1.4 : -1.4), *floor + 0.5);
    mov[i].velocity = Vec3(0.3, 0.0, 0);
  }
  RobotLimits tracked = RobotLimits::trackedRescue();
  RobotLimits disc = tracked;
  disc.drive = DriveType::kDifferential;
  disc.footprint.box = false;
  disc.footprint.radius_m = 0.3;
  disc.radius_m = disc.footprint.circumradius();
  RobotLimits car = tracked;
  car.drive = DriveType::kAckermann;
  for (const RobotLimits& robot : {tracked, disc, car}) {
    LocalParams params = LocalParams::preset(Method::kTian2016);
    params.robot = robot;
    World w;
    w.field = &*f;
    StatusOr<LocalPlanner> p = LocalPlanner::create(params, w);
    ASSERT_TRUE(p.ok()) << p.status().message();
    // The robot is placed along the roadway 5 cm a period at 0.5 m/s (as the local benchmark
    // does): every period is a real step wherever the commands would have taken it.
    const long before = g_allocations.load();
    int moving = 0;
    for (int k = 0; k < 300; ++k) {
      RobotState s;
      s.position = Vec3(1.5 + 0.05 * k, 0.4 * std::sin(0.05 * k), z);
      s.velocity = Vec3(0.5, 0.0, 0.0);
      s.yaw = 0.1 * std::sin(0.03 * k);
      const StepCommand c = p->step(s, path, mov.data(), mov.size(), 0.1);
      ASSERT_NE(c.status, StepStatus::kRefused) << driveTypeName(robot.drive) << " " << c.message;
      moving += c.velocity.norm() > 0.05;
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << driveTypeName(robot.drive);
    EXPECT_GT(moving, 150) << driveTypeName(robot.drive) << ": the robot should be driving on";
  }
}

}  // namespace
}  // namespace adit::local
