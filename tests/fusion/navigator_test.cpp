// SPDX-License-Identifier: BSD-3-Clause
// The Navigator on the bundled sealed roadway (maps/sealed_roadway_map.yaml, one 40 m
// drift, no other way through): map transactions, the blocked-path verdict, and the one-writer
// rule with a reader thread running while the navigator writes.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <thread>

#include "adit/fusion/navigator.hpp"
#include "adit/map/occupancy_map.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::fusion {
namespace {

const std::string kMap = std::string(ADIT_MAPS_DIR) + "/sealed_roadway_map.yaml";
const Vec3 kStart(3, 0, 1.6), kGoal(37, 0, 1.6);

Navigator makeNavigator(bool subgoals = false) {
  StatusOr<map::LoadedMap> loaded = map::loadMapAndSurvey(kMap);
  EXPECT_TRUE(loaded.ok()) << loaded.status().message();
  NavigatorParams p;
  p.local.robot.radius_m = 0.4;
  p.subgoals = subgoals;
  StatusOr<Navigator> nav = Navigator::create(std::move(loaded).value(), p, kGoal);
  EXPECT_TRUE(nav.ok()) << nav.status().message();
  Status s = nav->plan(kStart);
  EXPECT_TRUE(s.ok()) << s.message();
  return std::move(nav).value();
}

// Voxel centres (0.2 m grid) of a ball.
std::vector<Vec3> ball(const Vec3& c, double radius) {
  std::vector<Vec3> out;
  for (double x = -radius; x <= radius; x += 0.2)
    for (double y = -radius; y <= radius; y += 0.2)
      for (double z = -radius; z <= radius; z += 0.2)
        if (Vec3(x, y, z).norm() <= radius) out.push_back(c + Vec3(x, y, z));
  return out;
}

local::RobotState at(const Vec3& p) {
  local::RobotState s;
  s.position = p;
  return s;
}

TEST(Navigator, SensedRockBesideThePathUpdatesTheFieldLocallyWithoutReplanning) {
  Navigator nav = makeNavigator();
  const Vec3 boulder(20, 1.6, 0.4);  // against the north wall, off the axis the path follows
  double before = 0.0;
  nav.read([&](const map::OccupancyMap&, const map::DistanceField& f) { before = f.distance(boulder); });
  const NavigatorCycle c = nav.cycle(0.0, at(kStart), ball(boulder, 0.3), {}, 0.1);
  EXPECT_GT(c.inserted_points, 0);
  EXPECT_TRUE(c.field_updated);
  EXPECT_FALSE(c.field_update.full_rebuild);
  EXPECT_GT(c.field_update.voxels_recomputed, 0u);
  EXPECT_FALSE(c.replanned);
  EXPECT_EQ(c.status, NavigatorStatus::kDriving);
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
    EXPECT_FALSE(m.isFree(boulder));
    EXPECT_LT(f.distance(boulder), before);
  });
  // Sensing the same rock again changes nothing: the cycle stays cheap.
  const NavigatorCycle again = nav.cycle(0.1, at(kStart), ball(boulder, 0.3), {}, 0.1);
  EXPECT_EQ(again.inserted_points, 0);
  EXPECT_FALSE(again.field_updated);
}

// A scan is inserted as rays: a boulder the map holds is cleared once the sensor sees through
// where it was (it has been moved), and the field is updated over the reported box.
TEST(Navigator, ScanRaysClearRubbleThatIsGone) {
  Navigator nav = makeNavigator();
  const Vec3 boulder(12, 0.0, 1.6);
  ASSERT_GT(nav.cycle(0.0, at(kStart), ball(boulder, 0.3), {}, 0.1).inserted_points, 0);
  const Vec3 on_ray = boulder + Vec3(0.1, 0.1, 0.1);
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
    EXPECT_FALSE(m.isFree(boulder));
    EXPECT_FALSE(f.isFree(on_ray));
  });
  SensorScan scan;
  scan.origin = kStart;
  scan.max_range_m = 15.0;
  scan.returns = {Vec3(17.1, 0.1, 1.7)};  // a return far beyond, straight through the boulder
  const NavigatorCycle c = nav.cycleWithScan(0.1, at(kStart), scan, {}, 0.1);
  EXPECT_GT(c.map_change.to_free, 0u);
  EXPECT_EQ(c.map_change.to_occupied, 1u);
  EXPECT_EQ(c.inserted_points, 1);
  EXPECT_TRUE(c.field_updated);
  EXPECT_TRUE(c.map_change.box.contains(on_ray));
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
    EXPECT_TRUE(m.isFree(on_ray));                  // on the ray's line: cleared
    EXPECT_TRUE(f.isFree(on_ray));                  // and the field knows
    EXPECT_FALSE(m.isFree(Vec3(17.1, 0.1, 1.7)));  // the return: rock
  });
  // A bad scan is refused as a whole and reported, the robot keeps driving.
  SensorScan bad = scan;
  bad.max_range_m = -1.0;
  const NavigatorCycle b = nav.cycleWithScan(0.2, at(kStart), bad, {}, 0.1);
  EXPECT_FALSE(b.field_updated);
  ASSERT_FALSE(nav.events().empty());
  EXPECT_EQ(nav.events().back().type, "map_update_failed");
  EXPECT_EQ(b.status, NavigatorStatus::kDriving);
}

TEST(Navigator, RoofFallAcrossTheOnlyRoadwayStopsWithNoRoute) {
  Navigator nav = makeNavigator();
  const NavigatorCycle c = nav.cycle(4.0, at(Vec3(8, 0, 1.6)), ball(Vec3(20, 0, 1.6), 3.0), {}, 0.1);
  EXPECT_TRUE(c.replanned);
  EXPECT_EQ(c.status, NavigatorStatus::kNoRoute);
  EXPECT_EQ(c.command.velocity, Vec3::Zero());
  EXPECT_EQ(c.command.acceleration, Vec3::Zero());
  ASSERT_EQ(nav.events().size(), 1u);
  EXPECT_EQ(nav.events()[0].type, "no_route");
  EXPECT_NE(nav.events()[0].reason.find("expected path blocked"), std::string::npos) << nav.events()[0].reason;
  EXPECT_GT(nav.events()[0].replan_time_s, 0.0);
  // It stays stopped.
  const NavigatorCycle later = nav.cycle(4.1, at(Vec3(8, 0, 1.6)), {}, {}, 0.1);
  EXPECT_EQ(later.status, NavigatorStatus::kNoRoute);
  EXPECT_EQ(later.command.velocity, Vec3::Zero());
}

// A replan from where the robot stands inside the planner's margin (0.6 m from the north rib;
// the planner wants 0.7 m) is not refused: it starts up the field from the nearest valid pose and
// the path begins at the robot. With the back-off turned off the same cycle ends no_route.
TEST(Navigator, ReplanFromInsideTheMarginBacksOffInsteadOfRefusing) {
  const Vec3 pressed(10, 1.4, 1.6);
  const std::vector<Vec3> boulder = ball(Vec3(20, -1.3, 1.6), 1.0);  // on the axis, passable to the north
  for (const double back_off : {1.0, 0.0}) {
    StatusOr<map::LoadedMap> loaded = map::loadMapAndSurvey(kMap);
    ASSERT_TRUE(loaded.ok()) << loaded.status().message();
    NavigatorParams p;
    p.local.robot.radius_m = 0.4;
    p.replan_back_off_m = back_off;
    StatusOr<Navigator> nav = Navigator::create(std::move(loaded).value(), p, kGoal);
    ASSERT_TRUE(nav.ok()) << nav.status().message();
    ASSERT_TRUE(nav->plan(kStart).ok());
    nav->read([&](const map::OccupancyMap&, const map::DistanceField& f) {
      ASSERT_GT(f.distance(pressed), 0.4);  // the robot is clear of rock ...
      ASSERT_LT(f.distance(pressed), 0.7);  // ... but inside the margin
    });
    const NavigatorCycle c = nav->cycle(5.0, at(pressed), boulder, {}, 0.1);
    EXPECT_TRUE(c.replanned);
    if (back_off > 0.0) {
      EXPECT_EQ(c.status, NavigatorStatus::kDriving);
      const map::Polyline path = nav->expectedPath();
      ASSERT_GE(path.points.size(), 3u);
      EXPECT_LT((path.points.front() - pressed).norm(), 1e-9);
      nav->read([&](const map::OccupancyMap&, const map::DistanceField& f) {
        EXPECT_GE(f.distance(path.points[1]), 0.7 - 1e-6);  // the backed-off start is valid
        EXPECT_LT((path.points[1] - pressed).norm(), 1.0 + 1e-9);
        EXPECT_LT(path.points[1].y(), pressed.y());  // away from the north rib
      });
      ASSERT_FALSE(nav->events().empty());
      EXPECT_EQ(nav->events().back().type, "replan");
    } else {
      EXPECT_EQ(c.status, NavigatorStatus::kNoRoute);
      ASSERT_FALSE(nav->events().empty());
      EXPECT_NE(nav->events().back().message.find("does not fit"), std::string::npos) << nav->events().back().message;
    }
  }
}

// NavigatorParams::subgoals: a sub-goal in the annulus around the robot at the start of each
// period t0 (1 s), held in between; without, none.
TEST(Navigator, SubgoalsAreSelectedOncePerPeriod) {
  Navigator nav = makeNavigator(true);
  local::RobotState s = at(kStart);
  for (int k = 0; k < 25; ++k) {
    const NavigatorCycle c = nav.cycle(0.1 * k, s, {}, {}, 0.1);
    ASSERT_EQ(c.status, NavigatorStatus::kDriving) << c.command.message;
    ASSERT_TRUE(c.subgoal);
    if (k == 0) {
      const double r = (*c.subgoal - s.position).norm();
      EXPECT_GE(r, 0.6 - 1e-9);
      EXPECT_LE(r, 1.0 + 1e-9);
    }
    s.position += 0.1 * c.command.velocity;
    s.velocity = c.command.velocity;
  }
  EXPECT_EQ(nav.subgoalStats().periods, 3);  // t = 0, 1, 2 s
  EXPECT_GT(s.position.x(), kStart.x() + 0.3);

  Navigator plain = makeNavigator(false);
  EXPECT_FALSE(plain.cycle(0.0, at(kStart), {}, {}, 0.1).subgoal);
  EXPECT_EQ(plain.subgoalStats().periods, 0);

  NavigatorParams bad;
  bad.subgoals = true;
  bad.subgoal.t0_s = 0.0;
  EXPECT_NE(bad.validate().message().find("t0_s"), std::string::npos) << bad.validate().message();
}

TEST(Navigator, RefusesNonFiniteState) {
  Navigator nav = makeNavigator();
  const NavigatorCycle c = nav.cycle(0.0, at(Vec3(std::nan(""), 0, 0)), {}, {}, 0.1);
  EXPECT_EQ(c.status, NavigatorStatus::kRefused);
  EXPECT_EQ(c.command.velocity, Vec3::Zero());
}

// One writer (the cycle), one reader thread: rock is only ever added, so the distance a reader
// sees at a probe point never grows, and each read sees map and field agree (a voxel the map holds
// as rock has distance 0 in the field) - never half a transaction.
TEST(Navigator, ReaderThreadSeesWholeTransactionsOnly) {
  Navigator nav = makeNavigator();
  const Vec3 probe(20.1, 0.9, 1.5);  // a voxel centre the fifth slab fills
  std::atomic<bool> done{false};
  std::atomic<int> reads{0}, violations{0};
  std::thread reader([&] {
    double last = 1e9;
    while (!done.load()) {
      nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
        const double d = f.distance(probe);
        if (d > last + 1e-9) ++violations;
        if (!m.isFree(probe) && f.isFree(probe)) ++violations;
        last = d;
      });
      ++reads;
    }
  });
  // Rock grows from the north wall towards the axis one voxel row per cycle (voxel centres), and
  // stops 0.6 m short of it: the path along the axis stays clear.
  for (int k = 0; k < 6; ++k) {
    std::vector<Vec3> slab;
    for (double z = 0.1; z < 3.2; z += 0.2) slab.push_back(Vec3(20.1, 1.7 - 0.2 * k, z));
    // Interleave: the reader gets in between every two transactions (the machine may be busy).
    const int seen = reads.load();
    while (reads.load() < seen + 2) std::this_thread::yield();
    const NavigatorCycle c = nav.cycle(0.1 * k, at(kStart), slab, {}, 0.1);
    EXPECT_TRUE(c.field_updated);
    EXPECT_EQ(c.status, NavigatorStatus::kDriving);
  }
  nav.read([&](const map::OccupancyMap& m, const map::DistanceField& f) {
    EXPECT_FALSE(m.isFree(probe));
    EXPECT_FALSE(f.isFree(probe));
  });
  done = true;
  reader.join();
  EXPECT_GT(reads.load(), 0);
  EXPECT_EQ(violations.load(), 0);
}

// A generated bend (three segments; the plan has break points to refine).
const Vec3 kBendStart(1.4, 0.5, 1.5), kBendGoal(18.5, 10.8, 2.5);

Navigator bendNavigator(bool refine_plan, bool refine_replans) {
  map::SurveyNetwork net = test::bentRoadway(map::CrossSection::rectangle(4.0, 3.0), 0.2);
  map::LoadedMap loaded{test::voxelizeOrFail(net), net};
  NavigatorParams p;
  p.local.robot.radius_m = 0.4;
  p.global.seed = 3;
  p.refine_plan = refine_plan;
  p.refine_replans = refine_replans;
  StatusOr<Navigator> nav = Navigator::create(std::move(loaded), p, kBendGoal);
  EXPECT_TRUE(nav.ok()) << nav.status().message();
  Status s = nav->plan(kBendStart);
  EXPECT_TRUE(s.ok()) << s.message();
  return std::move(nav).value();
}

TEST(Navigator, RefinePlanFollowsTheRefinedPlan) {
  const Navigator plain = bendNavigator(false, false);
  const Navigator refined = bendNavigator(true, false);
  EXPECT_FALSE(plain.initialRefinement().has_value());
  ASSERT_TRUE(refined.initialRefinement().has_value());
  const PlanRefinement& ref = *refined.initialRefinement();
  ASSERT_EQ(ref.outcome, RefineOutcome::kRefined) << ref.message;
  // The same plan (same seed) as the plain navigator's, then refined: the expected path is the
  // refined one, and the global planner's motion check accepts it.
  const map::Polyline p = plain.expectedPath(), q = refined.expectedPath();
  ASSERT_EQ(ref.before_path.size(), p.size());
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(ref.before_path.points[i], p.points[i]);
  EXPECT_NEAR(q.length(), ref.after.length_m, 1e-9);
  EXPECT_NE(q.points[1], p.points[1]);
  const Status valid = refined.globalPlanner().validatePath(q);
  EXPECT_TRUE(valid.ok()) << valid.message();
}

// A boulder sensed on the expected path: the navigator replans round it; the replan is refined
// only with refine_replans, and the event says how long the refinement took.
TEST(Navigator, ReplansAreRefinedOnlyWhenAskedTo) {
  for (const bool refine_replans : {false, true}) {
    Navigator nav = bendNavigator(true, refine_replans);
    const map::Polyline path = nav.expectedPath();
    const Vec3 boulder = 0.5 * (path.points[1] + path.points[2]);
    const NavigatorCycle c = nav.cycle(1.0, at(kBendStart), ball(boulder, 0.4), {}, 0.1);
    ASSERT_TRUE(c.replanned) << refine_replans;
    EXPECT_EQ(c.status, NavigatorStatus::kDriving);
    ASSERT_EQ(nav.events().size(), 1u);
    const NavigatorEvent& e = nav.events()[0];
    EXPECT_EQ(e.type, "replan");
    if (refine_replans) {
      EXPECT_GT(e.refine_time_s, 0.0);
      EXPECT_LE(e.refine_time_s, e.replan_time_s);
    } else {
      EXPECT_EQ(e.refine_time_s, 0.0);
    }
    std::printf("boulder replan, refine_replans=%d: replan %.4f s, of it refinement %.4f s\n", int(refine_replans),
                e.replan_time_s, e.refine_time_s);
    const Status valid = nav.globalPlanner().validatePath(nav.expectedPath());
    EXPECT_TRUE(valid.ok()) << valid.message();
    // The initial refinement is still the first plan's.
    ASSERT_TRUE(nav.initialRefinement().has_value());
    EXPECT_NEAR(nav.initialRefinement()->after.length_m, path.length(), 1e-9);
  }
}

}  // namespace
}  // namespace adit::fusion
