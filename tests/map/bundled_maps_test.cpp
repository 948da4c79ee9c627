// SPDX-License-Identifier: BSD-3-Clause
// The bundled default district: what maps/README.md promises about it, and that the committed
// .bt is exactly what the survey voxelizes to (so it cannot go stale).
#include <gtest/gtest.h>

#include <cmath>

#include "adit/map/map_io.hpp"
#include "adit/map/map_summary.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {
namespace {

const std::string kDistrict = std::string(ADIT_MAPS_DIR) + "/district.yaml";
const std::string kDistrictBt = std::string(ADIT_MAPS_DIR) + "/district.bt";

double slopeDeg(const Vec3& a, const Vec3& b) {
  return std::atan2(std::abs(b.z() - a.z()), (b - a).head<2>().norm()) * 180.0 / M_PI;
}

TEST(BundledDistrict, IsTheDistrictTheReadmeDescribes) {
  StatusOr<SurveyNetwork> net = loadSurvey(kDistrict);
  ASSERT_TRUE(net.ok()) << net.status().toString();
  std::map<std::string, const SurveyRoadway*> by_name;
  for (const SurveyRoadway& r : net->roadways) by_name[r.name] = &r;
  for (const char* n : {"main-haulage", "return-airway", "tailgate", "headgate", "longwall-face"})
    ASSERT_TRUE(by_name.count(n)) << n;
  const double main_len = net->centreline(*by_name["main-haulage"]).length();
  const double return_len = net->centreline(*by_name["return-airway"]).length();
  EXPECT_NEAR(main_len, 600.0, 30.0);
  EXPECT_NEAR(return_len, 600.0, 30.0);
  EXPECT_NEAR(net->centreline(*by_name["tailgate"]).length(), 440.0, 20.0);   // 400 m beyond the return
  EXPECT_NEAR(net->centreline(*by_name["headgate"]).length(), 440.0, 20.0);
  // Links between main and return (cross-cuts and gate roads) every 50-80 m along the main.
  std::vector<double> link_x;
  for (const SurveyRoadway& r : net->roadways)
    if (r.stations.front()[0] == 'M' && r.stations[1][0] == 'R') link_x.push_back(net->stations.at(r.stations.front()).x());
  std::sort(link_x.begin(), link_x.end());
  ASSERT_GE(link_x.size(), 8u);
  for (std::size_t i = 1; i < link_x.size(); ++i) {
    EXPECT_GE(link_x[i] - link_x[i - 1], 50.0 - 1e-9);
    EXPECT_LE(link_x[i] - link_x[i - 1], 80.0 + 1e-9);
  }
  // Gradients of a few degrees; sections 4-5 m wide, 3-4 m high.
  for (const SurveyRoadway& r : net->roadways) {
    const Polyline line = net->centreline(r);
    for (std::size_t i = 1; i < line.size(); ++i) EXPECT_LT(slopeDeg(line.points[i - 1], line.points[i]), 6.0) << r.name;
  }
  for (const auto& [name, s] : net->sections) {
    EXPECT_GE(s.maxWidth(), 4.0) << name;
    EXPECT_LE(s.maxWidth(), 5.0) << name;
    EXPECT_GE(s.height(), 3.0) << name;
    EXPECT_LE(s.height(), 4.0) << name;
  }
}

TEST(BundledDistrict, CommittedOctreeIsTheVoxelizedSurvey) {
  StatusOr<SurveyNetwork> net = loadSurvey(kDistrict);
  ASSERT_TRUE(net.ok());
  StatusOr<OccupancyMap> from_yaml = voxelize(*net);
  ASSERT_TRUE(from_yaml.ok());
  StatusOr<OccupancyMap> from_bt = loadMap(kDistrictBt);
  ASSERT_TRUE(from_bt.ok()) << from_bt.status().toString();
  EXPECT_EQ(from_bt->stats().free_voxels, from_yaml->stats().free_voxels)
      << "maps/district.bt is stale: regenerate it with `adit map convert maps/district.yaml maps/district.bt`";
  EXPECT_EQ(from_bt->stats().occupied_voxels, from_yaml->stats().occupied_voxels);
  EXPECT_TRUE(from_bt->bounds().min.isApprox(from_yaml->bounds().min));
  EXPECT_TRUE(from_bt->bounds().max.isApprox(from_yaml->bounds().max));

  // Every centreline, 1 m above the floor, is free: junctions and bends are open.
  for (const SurveyRoadway& r : net->roadways) {
    const Polyline line = net->centreline(r);
    for (std::size_t i = 1; i < line.size(); ++i) {
      const double len = (line.points[i] - line.points[i - 1]).norm();
      for (double t = 0; t <= len; t += 0.5) {
        const Vec3 p = line.points[i - 1] + (t / len) * (line.points[i] - line.points[i - 1]) + Vec3(0, 0, 1.0);
        ASSERT_TRUE(from_bt->isFree(p)) << r.name << " at " << p.transpose();
      }
    }
  }
  // The footprint estimate of the roadway length agrees with the surveyed centrelines.
  StatusOr<RoadwayLengthEstimate> est = estimateRoadwayLength(*from_bt);
  ASSERT_TRUE(est.ok());
  EXPECT_NEAR(est->length_m, net->totalLength(), 0.05 * net->totalLength());
  EXPECT_NEAR(est->median_width_m, 4.5, 0.5);
}

}  // namespace
}  // namespace adit::map

namespace adit::map {
namespace {

TEST(OccupancyMapFromVoxels, BuildsTheGivenVoxelsAndRefusesBadInput) {
  std::vector<Vec3> free, occupied;
  for (int x = 0; x < 10; ++x) {
    free.emplace_back(0.05 + 0.1 * x, 0.05, 0.05);
    occupied.emplace_back(0.05 + 0.1 * x, 0.15, 0.05);
  }
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(0.1, free, occupied);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_EQ(m->stats().free_voxels, 10u);
  EXPECT_EQ(m->stats().occupied_voxels, 10u);
  EXPECT_TRUE(m->isFree({0.55, 0.05, 0.05}));
  EXPECT_EQ(m->state({0.55, 0.15, 0.05}), VoxelState::kOccupied);
  EXPECT_FALSE(OccupancyMap::fromVoxels(0.1, {}, occupied).ok());  // empty map: no free voxel
  EXPECT_FALSE(OccupancyMap::fromVoxels(-1.0, free, occupied).ok());
  const StatusOr<OccupancyMap> nan = OccupancyMap::fromVoxels(0.1, {Vec3(std::nan(""), 0, 0)}, {});
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.status().message().find("free voxel 0"), std::string::npos) << nan.status().message();
  EXPECT_FALSE(OccupancyMap::fromVoxels(0.1, {Vec3(1e6, 0, 0)}, {}).ok());  // off the key range
}

}  // namespace
}  // namespace adit::map
