// SPDX-License-Identifier: BSD-3-Clause
// A tracked ground robot in a real mine no survey describes: the Koutzi mine mesh of
// ../shared/data, imported at 0.2 m, with the campaign generator's scenarios (`adit campaign run
// --map koutzi.bt --generator` with the tracked robot). The roadway's floor curves up into its
// ribs, which the field's sphere (lifted off the floor) does not see; the robot's body does.
// Compiled in only when the data is there (ADIT_HAVE_MINE_DATA), so a fresh clone has no such test.
#include <gtest/gtest.h>
#ifdef ADIT_HAVE_MINE_DATA
#include <unistd.h>

#include <filesystem>
#include <string>

#include "adit/map/free_space.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/readers/import.hpp"
#include "adit/map/world.hpp"
#include "adit/sim/batch.hpp"

namespace adit::sim {
namespace {

namespace fs = std::filesystem;

// Scenarios 9 and 13 of `--seed 1`, both ending in contact before. In 9 the robot, turning toward
// the goal's roadway with its heading still on the rib, drove forward along that heading; the
// field's sphere saw room, the band (the rock the body meets, here the floor rising into the rib)
// did not stop it, and the body's low corner touched the rib's foot: its stopping runs now keep
// clear of the band too. In 13 the floor rose a voxel a column into the rib (0.4 m within half a
// metre), which every step and slope test between columns passed: the band now also holds the
// body's underside over the floor's plane.
TEST(RealMineGround, KoutziTrackedRobotKeepsItsBodyOffTheRibsFoot) {
  StatusOr<map::Geometry> g = map::readGeometry(std::string(ADIT_SHARED_DATA_DIR) + "/koutzi_mine_mesh/GM-KUM.stl");
  ASSERT_TRUE(g.ok()) << g.status().message();
  map::ImportParams ip;
  ip.resolution_m = 0.2;
  ip.seed = map::Vec3(0, 0, 2);
  StatusOr<map::ImportResult> imported = map::buildMapFromGeometry(*g, ip);
  ASSERT_TRUE(imported.ok()) << imported.status().message();
  const fs::path dir = fs::temp_directory_path() / ("adit_real_ground_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bt = (dir / "koutzi.bt").string();
  ASSERT_TRUE(map::writeOctomap(imported->map, bt).ok());

  // What `adit campaign run --map koutzi.bt` sets up (tools/common/batch_runner.cpp).
  StatusOr<Scenario> base = parseScenario("map: " + bt +
                                              "\nstart: [0, 0, 0]\ngoal: [1, 0, 0]\nexpected_path: plan\n"
                                              "robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 8}\n"
                                              "method: tian2016\nparams: {rho0_m: 1.0}\ndt: 0.1\n",
                                          "batch");
  ASSERT_TRUE(base.ok()) << base.status().message();
  StatusOr<map::World> world = map::World::load(bt);
  ASSERT_TRUE(world.ok()) << world.status().message();
  StatusOr<BatchRoadways> roadways =
      BatchRoadways::fromFreeSpace(world->map(), world->field(), base->params.robot.radius_m + 0.4);
  ASSERT_TRUE(roadways.ok()) << roadways.status().message();
  StatusOr<Environment> truth = Environment::borrow(*world);
  ASSERT_TRUE(truth.ok());
  StatusOr<BatchParams> params = parseBatchParams(
      "robot: {mode: ground, drive: skid, footprint: \"box:1.0,0.7\", height: 0.6, v_max: 1.0, a_max: 0.5, "
      "omega_max: 1.0, alpha_max: 2.0, max_slope_deg: 15, max_step: 0.1}\n",
      "generator");
  ASSERT_TRUE(params.ok()) << params.status().message();
  params->seed = 1;
  for (int index : {9, 13}) {
    StatusOr<Scenario> sc = makeBatchScenario(*base, *roadways, *truth, *params, index);
    ASSERT_TRUE(sc.ok()) << sc.status().message();
    const BatchRunResult r = runBatchScenario(*sc, *truth, index, &*world);
    std::printf("koutzi ground scenario %d: %s, %.1f s, %d collisions, least clearance %.3f m %s\n", index,
                r.outcome.c_str(), r.arrival_time_s, r.collisions, r.min_clearance_m, r.message.c_str());
    EXPECT_EQ(r.collisions, 0) << index << ": " << r.message;
    EXPECT_EQ(r.outcome, "arrived") << index << ": " << r.message;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace adit::sim
#endif  // ADIT_HAVE_MINE_DATA
