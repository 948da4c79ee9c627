// SPDX-License-Identifier: BSD-3-Clause
// map::World, the one loader behind plan, the navigator, simulation, campaigns and serve: it gives
// the field a fresh DistanceField::build gives, its copy() shares nothing a change reaches, and a
// move keeps the addresses planners hold. Oracle: a field built from scratch, queried at random.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>
#include <unistd.h>

#include "adit/map/map_io.hpp"
#include "adit/map/world.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

LoadedMap roadway(double res = 0.2) {
  SurveyNetwork net = test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 20.0, res);
  return LoadedMap{test::voxelizeOrFail(net), net};
}

void expectSameField(const DistanceField& a, const DistanceField& b, const Aabb& box) {
  std::mt19937_64 rng(5);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p = test::randomPoint(rng, box);
    ASSERT_EQ(a.isFree(p), b.isFree(p)) << p.transpose();
    ASSERT_DOUBLE_EQ(a.distance(p), b.distance(p)) << p.transpose();
  }
}

TEST(World, LoadGivesTheFieldAFreshBuildGives) {
  const std::string dir = testing::TempDir() + "adit_world_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string bt = dir + "/roadway.bt";
  LoadedMap loaded = roadway();
  ASSERT_TRUE(writeOctomap(loaded.map, bt).ok());
  StatusOr<World> w = World::load(bt);
  ASSERT_TRUE(w.ok()) << w.status().message();
  EXPECT_EQ(w->path(), bt);
  EXPECT_EQ(w->survey(), nullptr);  // a .bt has no survey beside it
  EXPECT_GE(w->times().load_s, 0.0);
  EXPECT_GE(w->times().field_s, 0.0);
  StatusOr<OccupancyMap> again = loadMap(bt);
  ASSERT_TRUE(again.ok());
  StatusOr<DistanceField> fresh = DistanceField::build(*again);
  ASSERT_TRUE(fresh.ok());
  expectSameField(w->field(), *fresh, w->map().bounds());
  std::filesystem::remove_all(dir);
}

TEST(World, LoadErrorsNameTheFile) {
  const std::string missing = testing::TempDir() + "no_such_map_here.bt";
  StatusOr<World> w = World::load(missing);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.status().message().find("no_such_map_here.bt"), std::string::npos) << w.status().message();
}

TEST(World, CopySharesNothingAChangeReaches) {
  StatusOr<World> base = World::build(roadway(), "roadway");
  ASSERT_TRUE(base.ok());
  ASSERT_NE(base->survey(), nullptr);
  World belief = base->copy();
  EXPECT_EQ(belief.path(), "roadway");
  ASSERT_NE(belief.survey(), nullptr);
  EXPECT_NE(belief.survey(), base->survey());
  const Vec3 rubble(10.1, 0.1, 1.1);
  const double before = base->field().distance(rubble);
  MapChange c;
  ASSERT_TRUE(belief.map().setVoxels({rubble}, VoxelState::kOccupied, &c).ok());
  ASSERT_TRUE(belief.field().update(belief.map(), c.box.inflated(belief.field().resolution())).ok());
  EXPECT_FALSE(belief.map().isFree(rubble));
  EXPECT_FALSE(belief.field().isFree(rubble));
  // The original saw none of it.
  EXPECT_TRUE(base->map().isFree(rubble));
  EXPECT_TRUE(base->field().isFree(rubble));
  EXPECT_DOUBLE_EQ(base->field().distance(rubble), before);
}

TEST(World, AMoveKeepsTheAddressesPlannersHold) {
  StatusOr<World> w = World::build(roadway());
  ASSERT_TRUE(w.ok());
  const OccupancyMap* map = &w->map();
  const DistanceField* field = &w->field();
  World moved = std::move(w).value();
  EXPECT_EQ(&moved.map(), map);
  EXPECT_EQ(&moved.field(), field);
}

TEST(World, FromPartsRefusesAFieldOfAnotherMap) {
  LoadedMap coarse = roadway(0.4);
  StatusOr<DistanceField> field = DistanceField::build(coarse.map);
  ASSERT_TRUE(field.ok());
  StatusOr<World> w = World::fromParts(roadway(0.2), std::move(field).value(), "fine.bt");
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.status().message().find("fine.bt"), std::string::npos) << w.status().message();
  EXPECT_NE(w.status().message().find("was not built from the map"), std::string::npos);
}

}  // namespace
}  // namespace adit::map
