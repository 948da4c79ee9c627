// SPDX-License-Identifier: BSD-3-Clause
// The Navigator on the bundled sealed roadway (maps/scenarios/sealed_roadway_map.yaml, one 40 m
// drift, no other way through): map transactions, the blocked-path verdict, and the one-writer
// rule with a reader thread running while the navigator writes.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "adit/fusion/navigator.hpp"
#include "adit/map/occupancy_map.hpp"

namespace adit::fusion {
namespace {

const std::string kMap = std::string(ADIT_MAPS_DIR) + "/scenarios/sealed_roadway_map.yaml";
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

}  // namespace
}  // namespace adit::fusion
